//! The `sinscal` command line.

mod calibrate;
mod compensate;
mod import;
mod noise;
mod noise_file;
mod sensor_noise;
mod simulate_sensors;
mod simulate_thermal;
mod thermal;

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::{Parser, Subcommand, ValueEnum};
use rand::SeedableRng;

use sinscal_core::io::data::DataFormat;
use std::sync::atomic::AtomicBool;

use sinscal_core::calib::plan::{plan, PlanInput};
use sinscal_core::calib::EstimateOptions;
use sinscal_core::design::{design, Axes, DesignRequest, Target};
use sinscal_core::diagnose::plot::gap_svg;
use sinscal_core::diagnose::DiagnoseOptions;
use sinscal_core::io::meta::{read_json, write_json, RunMetadata, Truth};
use sinscal_core::io::run::{metadata_sidecar, write_simulated_run};
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::Site;
use sinscal_core::pipeline::diagnose_file;
use sinscal_core::sim::{HandTurns, Noise, Scheme, SchemeRef, SimConfig};

#[derive(Parser)]
#[command(
    name = "sinscal",
    version,
    about = "Calibration of strapdown inertial navigation systems"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a calibration run (SPEC §4–5): from a truth file, or from
    /// a scheme and a parameter set.
    Simulate(SimulateArgs),
    /// Calibrate a run: the 24 parameters with their 1-σ.
    Calibrate(calibrate::CalibrateArgs),
    /// Predict the 1-σ a scheme reaches at a given noise, before any data.
    Plan(PlanArgs),
    /// Design the shortest scheme whose predicted 1-σ meets an accuracy
    /// target for every parameter.
    Design(DesignArgs),
    /// Find where the run and a simulation of its calibration disagree,
    /// name the effect outside the base model that explains it, add it
    /// and show the gap shrink.
    Diagnose(DiagnoseArgs),
    /// The overlapping Allan deviation of every axis over the run's dwells
    /// (or a whole static run) and the noise terms read from it: ARW/VRW,
    /// bias instability, rate random walk.
    Noise(noise::NoiseArgs),
    /// Write a log of another format as a run of the contract.
    #[command(subcommand)]
    Import(import::ImportCommand),
    /// Apply a calibration to a run: every record through the exact
    /// inversion of the error model, streaming, into a run of the contract.
    Compensate(compensate::CompensateArgs),
    /// Write a result's compensation file (JSON, or CSV by the name).
    Export(compensate::ExportArgs),
    /// A unit's thermal model (SPEC §3a) from results of soaked runs.
    Thermal(thermal::ThermalArgs),
    /// Run the calibration server (HTTP API under /api/v1).
    Serve(sinscal_server::config::ServeArgs),
    /// Run calibration workers only, on the database the servers share
    /// (`--database-url postgres://…`); `--bind` serves /healthz, /readyz
    /// and /metrics.
    Worker(sinscal_server::config::ServeArgs),
    /// Manage the server's bearer tokens.
    #[command(subcommand)]
    Token(TokenCommand),
}

#[derive(Subcommand)]
enum TokenCommand {
    /// Create a token and print it, alone on stdout, once (only its hash
    /// is stored).
    Create {
        /// station (uploads), engineer (reads), admin (tokens, deletes).
        #[arg(long)]
        role: sinscal_server::store::Role,
        #[arg(long, env = "SINSCAL_DATA_DIR", default_value = sinscal_server::config::defaults::DATA_DIR)]
        data_dir: PathBuf,
        /// The servers' database (as `serve --database-url`); default:
        /// SQLite in the data folder.
        #[arg(long, env = "SINSCAL_DATABASE_URL")]
        database_url: Option<String>,
        /// A note naming the token's holder.
        #[arg(long)]
        label: Option<String>,
    },
}

#[derive(clap::Args)]
struct DiagnoseArgs {
    /// The run's data file (CSV, gzip CSV or f64le).
    run: PathBuf,
    /// Its metadata; default: the sidecar beside it (run.csv → run.json).
    #[arg(long)]
    meta: Option<PathBuf>,
    /// Write the report (JSON) here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write the gap plot (SVG) here.
    #[arg(long)]
    svg: Option<PathBuf>,
}

#[derive(clap::Args)]
struct PlanArgs {
    /// Built-in scheme name or a JSON scheme file.
    #[arg(long)]
    scheme: String,
    /// Dwell of a built-in scheme, s.
    #[arg(long)]
    dwell: Option<f64>,
    #[command(flatten)]
    noise: sensor_noise::SensorNoiseArgs,
    #[arg(long, default_value_t = 100.0)]
    rate: f64,
    #[arg(long, default_value_t = Site::REFERENCE.latitude_deg)]
    latitude: f64,
    /// Assume zero velocity also during rotations (turntable axes through
    /// the reference point).
    #[arg(long)]
    zupt_in_motion: bool,
    /// The unit's start attitude as `simulate --attitude-error` takes it:
    /// rotation vector in n, degrees, "x,y,z" (a heading ψ is "0,0,ψ").
    /// It matters for turns about navigation axes.
    #[arg(long, value_parser = parse_triple, allow_hyphen_values = true)]
    attitude_error: Option<[f64; 3]>,
    /// Write the plan as JSON here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also say what a run of the scheme would name: the smallest size of
    /// each SPEC §3 effect the discrepancy workflow would detect.
    #[arg(long)]
    detect: bool,
}

#[derive(clap::Args)]
struct DesignArgs {
    /// `table1` (the seed paper's Table 1) or a JSON file of accuracies
    /// by parameter name, canonical units (others keep Table 1).
    #[arg(long, default_value = "table1")]
    target: String,
    /// Divide every target by this (3: three times tighter).
    #[arg(long, default_value_t = 1.0)]
    tighten: f64,
    /// Predicted σ must be at most target / margin.
    #[arg(long, default_value_t = 3.0)]
    margin: f64,
    #[command(flatten)]
    noise: sensor_noise::SensorNoiseArgs,
    /// The axes the table turns the unit about.
    #[arg(long, value_enum, default_value_t = Axes::default())]
    axes: Axes,
    /// Turn rate, deg/s.
    #[arg(long, default_value_t = 10.0)]
    rate_dps: f64,
    /// Turn acceleration, deg/s².
    #[arg(long, default_value_t = 20.0)]
    accel_dps2: f64,
    /// Shortest dwell, s.
    #[arg(long, default_value_t = 60.0)]
    min_dwell: f64,
    /// Longest dwell the search considers, s.
    #[arg(long, default_value_t = 3600.0)]
    max_dwell: f64,
    /// Most turns in the scheme.
    #[arg(long, default_value_t = 24)]
    max_turns: usize,
    /// Longest acceptable run, s.
    #[arg(long)]
    max_duration: Option<f64>,
    /// Score the scheme as an operator turns it by hand (SPEC §4).
    #[arg(long)]
    by_hand: bool,
    /// Seed of the hand turns.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long, default_value_t = Site::REFERENCE.latitude_deg)]
    latitude: f64,
    /// The unit's start attitude, rotation vector in n, degrees "x,y,z".
    #[arg(long, value_parser = parse_triple, allow_hyphen_values = true)]
    attitude_error: Option<[f64; 3]>,
    /// Effects the discrepancy workflow must name on a run of the scheme,
    /// "accel_lever_arm=2cm,accel_delay=0.5ms" (SPEC §3 names, sizes with
    /// their units).
    #[arg(long, value_delimiter = ',')]
    detect: Vec<sinscal_core::design::DetectGoal>,
    /// Write the scheme (SPEC §4 JSON) here.
    #[arg(long)]
    out: PathBuf,
    /// Also write the whole design (predictions, comparisons) as JSON here.
    #[arg(long)]
    report: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum)]
enum ParamSet {
    /// The seed paper's Table 1 truth.
    Paper,
    /// All 24 parameters zero.
    Zero,
    /// Each parameter uniform in ±2× the paper's magnitude (seeded).
    Random,
}

#[derive(clap::Args)]
struct SimulateArgs {
    /// A truth file (SPEC §5) to simulate exactly.
    #[arg(long, conflicts_with_all = ["scheme", "params", "dwell"])]
    truth: Option<PathBuf>,
    /// Output folder: run data, run.json, truth.json.
    #[arg(long)]
    out: PathBuf,
    #[arg(long, value_enum, default_value_t = DataFormat::default())]
    format: DataFormat,
    /// Gzip the CSV.
    #[arg(long)]
    gzip: bool,
    /// Sample rate, Hz (overrides the truth's).
    #[arg(long)]
    rate: Option<f64>,
    /// Built-in scheme name or a JSON scheme file.
    #[arg(long)]
    scheme: Option<String>,
    /// Dwell of a built-in scheme, s.
    #[arg(long)]
    dwell: Option<f64>,
    #[arg(long, value_enum)]
    params: Option<ParamSet>,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Gyro angle random walk, deg/√h.
    #[arg(long, default_value_t = 0.0003)]
    arw: f64,
    /// Accelerometer velocity random walk, µg/√Hz.
    #[arg(long, default_value_t = 5.0)]
    vrw: f64,
    /// Effects of SPEC §3 as a JSON file.
    #[arg(long)]
    effects: Option<PathBuf>,
    /// Initial attitude error, rotation vector in n, degrees: "x,y,z".
    #[arg(long, value_parser = parse_triple, allow_hyphen_values = true)]
    attitude_error: Option<[f64; 3]>,
    /// Unit serial written into run.json.
    #[arg(long, default_value = "SIM-0001")]
    serial: String,
    /// Turn the scheme by hand (SPEC §4): every turn becomes a flip about
    /// an axis 1–5° off, ±2° in angle, 30–120 °/s, the unit lifted 2–8 cm
    /// and set down 1–5 cm away; truth.json holds the flips.
    #[arg(long)]
    manual: bool,
    /// Seed of the hand turns; default: the run's seed.
    #[arg(long, requires = "manual")]
    manual_seed: Option<u64>,
    #[arg(long, default_value_t = Site::REFERENCE.latitude_deg)]
    latitude: f64,
    #[arg(long, default_value_t = Site::REFERENCE.longitude_deg)]
    longitude: f64,
    #[arg(long, default_value_t = Site::REFERENCE.height_m)]
    height: f64,
    #[command(flatten)]
    thermal: simulate_thermal::ThermalArgs,
    #[command(flatten)]
    sensors: simulate_sensors::SensorArgs,
}

fn scheme_ref(arg: &str) -> anyhow::Result<SchemeRef> {
    let path = PathBuf::from(arg);
    if path.exists() {
        read_json(&path).with_context(|| format!("reading scheme {arg}"))
    } else {
        Ok(SchemeRef::Name(arg.to_string()))
    }
}

fn simulate_config(a: &SimulateArgs) -> anyhow::Result<SimConfig> {
    let mut cfg = nominal_simulate_config(a)?;
    if a.manual {
        let seed = a.manual_seed.unwrap_or(cfg.seed);
        cfg.scheme = Scheme::by_hand(&cfg.scheme, seed, &HandTurns::default())
            .map_err(anyhow::Error::msg)?;
    }
    a.thermal.apply(&mut cfg)?;
    a.sensors.apply(&mut cfg)?;
    Ok(cfg)
}

fn nominal_simulate_config(a: &SimulateArgs) -> anyhow::Result<SimConfig> {
    if let Some(path) = &a.truth {
        let truth: Truth = read_json(path)?;
        let mut cfg = truth.to_sim_config()?;
        if let Some(rate) = a.rate {
            cfg.sample_rate_hz = rate;
        }
        return Ok(cfg);
    }
    let (Some(scheme), Some(params)) = (&a.scheme, a.params) else {
        bail!("give either --truth FILE, or --scheme and --params");
    };
    let scheme = scheme_ref(scheme)?
        .resolve(a.dwell)
        .map_err(anyhow::Error::msg)?;
    let params = match params {
        ParamSet::Paper => ErrorParameters::paper(),
        ParamSet::Zero => ErrorParameters::zero(),
        ParamSet::Random => {
            // A stream of its own, so the truth does not shift the noise.
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(a.seed);
            rng.set_stream(1);
            ErrorParameters::random(&mut rng)
        }
    };
    let effects: Effects = match &a.effects {
        Some(p) => read_json(p)?,
        None => Effects::none(),
    };
    let attitude = a.attitude_error.unwrap_or([0.0; 3]);
    Ok(SimConfig {
        site: Site::new(a.latitude, a.longitude, a.height),
        sample_rate_hz: a.rate.unwrap_or(100.0),
        scheme,
        params,
        effects,
        noise: Noise::white(a.arw, a.vrw),
        initial_attitude_error_deg: attitude,
        seed: a.seed,
        thermal: None,
        temperature: None,
    })
}

fn run_simulate(a: SimulateArgs) -> anyhow::Result<()> {
    let cfg = simulate_config(&a)?;
    let format = a.format;
    if a.gzip && format == DataFormat::F64le {
        bail!("--gzip applies to CSV only");
    }
    let files = write_simulated_run(&cfg, &a.out, format, a.gzip, &a.serial)?;
    eprintln!(
        "wrote {} records to {} ({}, {})",
        files.records,
        files.data.display(),
        files.metadata.display(),
        files.truth.display()
    );
    Ok(())
}

/// The run's metadata: `--meta`, else the sidecar beside the data file.
fn read_metadata(
    run: &std::path::Path,
    meta: Option<&std::path::Path>,
) -> anyhow::Result<RunMetadata> {
    let path = meta.map_or_else(|| metadata_sidecar(run), PathBuf::from);
    let text = std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
    RunMetadata::from_json(&text).with_context(|| format!("in {}", path.display()))
}

/// Prints a progress line on stderr whenever the stage changes.
pub(crate) fn print_stage(p: &sinscal_core::calib::Progress, last_stage: &mut String) {
    if p.stage != *last_stage {
        eprintln!("{:>3.0}% {}", 100.0 * p.fraction, p.stage);
        *last_stage = p.stage.clone();
    }
}

fn run_plan(a: PlanArgs) -> anyhow::Result<()> {
    let scheme = scheme_ref(&a.scheme)?
        .resolve(a.dwell)
        .map_err(anyhow::Error::msg)?;
    let input = PlanInput {
        scheme,
        site: Site::new(a.latitude, 0.0, 0.0),
        sample_rate_hz: a.rate,
        noise: a.noise.density()?,
        initial_attitude_error_deg: a.attitude_error.unwrap_or([0.0; 3]),
    };
    let opts = EstimateOptions {
        zupt_in_motion: a.zupt_in_motion,
        ..EstimateOptions::default()
    };
    let plan = plan(&input, &opts)?;
    let detectable = if a.detect {
        Some(sinscal_core::diagnose::thresholds_before_data(
            &input,
            &AtomicBool::new(false),
        )?)
    } else {
        None
    };
    println!(
        "scheme {} ({:.2} h), ARW {} deg/sqrt(h), VRW {} ug/sqrt(Hz): predicted 1-sigma",
        plan.scheme,
        plan.duration_s / 3600.0,
        a.noise.arw,
        a.noise.vrw
    );
    for info in sinscal_core::model::PARAMETERS.iter() {
        if let Some(p) = plan.parameters.get(info.name) {
            println!("{:<20} {:>12.5}  {}", info.name, p.sigma, p.unit);
        }
    }
    for w in &plan.warnings {
        println!("warning: {w}");
    }
    if let Some(t) = &detectable {
        println!(
            "a run of this scheme would name {}",
            sinscal_core::diagnose::detect::describe(t)
        );
    }
    if let Some(out) = &a.out {
        let mut json = serde_json::to_value(&plan)?;
        if let Some(t) = &detectable {
            json["detectable"] = serde_json::to_value(t)?;
        }
        write_json(out, &json)?;
    }
    Ok(())
}

fn run_design(a: DesignArgs) -> anyhow::Result<()> {
    let target = if a.target == "table1" {
        Target::table1()
    } else {
        let text = std::fs::read(&a.target).with_context(|| format!("reading {}", a.target))?;
        Target::from_json(&a.target, &text)?
    };
    let target = if a.tighten == 1.0 {
        target
    } else {
        target.tightened(a.tighten)
    };
    let req = DesignRequest {
        target: Some(target),
        noise: a.noise.density()?,
        axes: a.axes,
        rate_dps: a.rate_dps,
        accel_dps2: a.accel_dps2,
        min_dwell_s: a.min_dwell,
        max_dwell_s: a.max_dwell,
        max_turns: a.max_turns,
        max_duration_s: a.max_duration,
        margin: a.margin,
        by_hand: a.by_hand,
        seed: a.seed,
        site: Site {
            latitude_deg: a.latitude,
            ..Site::REFERENCE
        },
        initial_attitude_deg: a.attitude_error.unwrap_or([0.0; 3]),
        time_limit_s: None,
        detect: a.detect,
    };
    let d = design(&req)?;
    print!("{}", d.summary());
    write_json(&a.out, &d.scheme)?;
    eprintln!("wrote {}", a.out.display());
    if let Some(path) = &a.report {
        write_json(path, &d)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn run_diagnose(a: DiagnoseArgs) -> anyhow::Result<()> {
    let meta = read_metadata(&a.run, a.meta.as_deref())?;
    let cancel = AtomicBool::new(false);
    let mut last_stage = String::new();
    let report = diagnose_file(
        &a.run,
        &meta,
        &DiagnoseOptions::default(),
        &mut |p| print_stage(&p, &mut last_stage),
        &cancel,
    )?;
    print!("unit {}\n{}", meta.unit_serial, report.summary());
    if let Some(out) = &a.out {
        write_json(out, &report)?;
        eprintln!("wrote {}", out.display());
    }
    if let Some(svg) = &a.svg {
        std::fs::write(svg, gap_svg(&report))
            .with_context(|| format!("writing {}", svg.display()))?;
        eprintln!("wrote {}", svg.display());
    }
    Ok(())
}

/// "x,y,z" as three numbers. One value, not three, so that the flag may
/// stand anywhere on the command line.
fn parse_triple(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<Result<_, _>>()?;
    <[f64; 3]>::try_from(v).map_err(|v| format!("expected x,y,z, got {} numbers", v.len()))
}

/// Runs one command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Simulate(a) => run_simulate(a),
        Command::Calibrate(a) => {
            let meta = read_metadata(&a.run, a.meta.as_deref())?;
            calibrate::run_calibrate(a, meta)
        }
        Command::Plan(a) => run_plan(a),
        Command::Diagnose(a) => run_diagnose(a),
        Command::Design(a) => run_design(a),
        Command::Noise(a) => noise::run_noise(&a, &read_metadata(&a.run, a.meta.as_deref())?),
        Command::Compensate(a) => {
            compensate::run_compensate(&a, &read_metadata(&a.run, a.meta.as_deref())?)
        }
        Command::Export(a) => compensate::run_export(&a),
        Command::Import(c) => import::run_import(&c),
        Command::Thermal(a) => thermal::run_thermal(&a),
        Command::Serve(a) => Ok(sinscal_server::server::serve(&a)?),
        Command::Worker(a) => Ok(sinscal_server::server::worker(&a)?),
        Command::Token(TokenCommand::Create {
            role,
            data_dir,
            database_url,
            label,
        }) => {
            let token = sinscal_server::server::create_token(
                &data_dir,
                database_url.as_deref(),
                role,
                label.as_deref(),
            )?;
            println!("{token}");
            Ok(())
        }
    }
}
