//! Speed of scheme design: the objective on the built-in schemes (one
//! scheme scored) and whole designs, wall time, one core.
//!
//! `cargo bench --bench design` runs the Table 1 design at navigation-grade
//! noise (ARW 0.0003 deg/√h, VRW 5 µg/√Hz, body axes, 10 °/s, margin 3),
//! the same at margin 2.2, three times tighter (margin 3), and for a table
//! with navigation axes; `-- --quick` only the objective.

use std::time::Instant;

use sinscal::design::information::scheme_information;
use sinscal::design::{design, objective_settings, Axes, DesignRequest, Target};
use sinscal::sim::Scheme;

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
    ];
    for (what, req) in cases {
        let t = Instant::now();
        match design(&req) {
            Ok(d) => println!(
                "design {what}: {:.2} h ({} dwells), binding {:?}, {} schemes scored in {:.1} s",
                d.duration_s / 3600.0,
                d.scheme.counts().0,
                d.binding,
                d.evaluations,
                t.elapsed().as_secs_f64()
            ),
            Err(e) => println!("design {what}: {e} ({:.1} s)", t.elapsed().as_secs_f64()),
        }
    }
}
