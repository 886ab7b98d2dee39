//! Speed of scheme design: the objective on the built-in schemes (one
//! scheme scored) and whole designs, wall time, one core.
//!
//! `cargo bench --bench design` runs the Table 1 design at navigation-grade
//! noise (ARW 0.0003 deg/√h, VRW 5 µg/√Hz, body axes, 10 °/s, margin 3),
//! the same at margin 2.2, three times tighter (margin 3), for a table
//! with navigation axes, with a 2 cm lever arm and a 0.5 ms delay to detect
//! (margin 3 and 2.2), and a gyro drift to detect at tactical noise, where
//! the workflow's check tightens the objective for a second search;
//! `-- --quick` only the objective.

use std::time::Instant;

use sinscal_core::design::information::scheme_information;
use sinscal_core::design::{design, objective_settings, Axes, DesignRequest, DetectGoal, Target};
use sinscal_core::sim::Scheme;

fn goals(items: &[&str]) -> Vec<DetectGoal> {
    items.iter().map(|g| g.parse().unwrap()).collect()
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let settings = objective_settings(&DesignRequest::default());
    for (name, dwell) in [("ten-position", 300.0), ("ten-position-9+9", 600.0)] {
        let scheme = Scheme::builtin(name, dwell).unwrap();
        let n = 20;
        let t = Instant::now();
        let mut duration = 0.0;
        for _ in 0..n {
            duration = scheme_information(&scheme, &settings).unwrap().duration_s;
        }
        println!(
            "objective, {name} {dwell} s dwells ({:.2} h): {:.1} ms per scheme",
            duration / 3600.0,
            t.elapsed().as_secs_f64() * 1e3 / n as f64
        );
    }
    if quick {
        return;
    }
    let cases = [
        ("table1, margin 3", DesignRequest::default()),
        (
            "table1, margin 2.2",
            DesignRequest {
                margin: 2.2,
                ..DesignRequest::default()
            },
        ),
        (
            "table1 / 3, margin 3",
            DesignRequest {
                target: Some(Target::table1().tightened(3.0)),
                ..DesignRequest::default()
            },
        ),
        (
            "table1, margin 3, navigation axes",
            DesignRequest {
                axes: Axes::Nav,
                ..DesignRequest::default()
            },
        ),
        (
            "table1, margin 3, detect accel_lever_arm=2cm,accel_delay=0.5ms",
            DesignRequest {
                detect: goals(&["accel_lever_arm=2cm", "accel_delay=0.5ms"]),
                ..DesignRequest::default()
            },
        ),
        (
            "table1, margin 2.2, detect accel_lever_arm=2cm,accel_delay=0.5ms",
            DesignRequest {
                margin: 2.2,
                detect: goals(&["accel_lever_arm=2cm", "accel_delay=0.5ms"]),
                ..DesignRequest::default()
            },
        ),
        (
            "tactical (ARW 0.001, VRW 10), table1 × 5, detect bias_drift=0.03deg/h/h",
            DesignRequest {
                target: Some(Target::table1().tightened(0.2)),
                noise: sinscal_core::calib::NoiseDensity::white(0.001, 10.0),
                detect: goals(&["bias_drift=0.03deg/h/h"]),
                ..DesignRequest::default()
            },
        ),
    ];
    for (what, req) in cases {
        let t = Instant::now();
        match design(&req) {
            Ok(d) => {
                println!(
                    "design {what}: {:.2} h ({} dwells), binding {:?}, {} schemes scored in {:.1} s",
                    d.duration_s / 3600.0,
                    d.scheme.counts().0,
                    d.binding,
                    d.evaluations,
                    t.elapsed().as_secs_f64()
                );
                for o in &d.detect {
                    println!("  {}", o.describe());
                }
            }
            Err(e) => println!("design {what}: {e} ({:.1} s)", t.elapsed().as_secs_f64()),
        }
    }
}
