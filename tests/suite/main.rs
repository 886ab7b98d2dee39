//! The integration suite, one test binary: each module is one capability
//! tested end to end (a real server on a random port, real files, the
//! `sinscal` binary as a child process), `common` their harness, the
//! `*_support` modules the set-ups several share. One binary, not one per
//! file: each test binary links the whole library and the harness, and
//! some forty of them were most of the suite's build time. libtest's
//! threads run tests of every module side by side; a module is picked by
//! name, e.g. `cargo test --test suite api_upload::`.

mod common;
mod diagnosis_support;
mod model_check_support;
mod table1_support;
mod thermal_support;

mod api_acceptance;
mod api_calibration;
mod api_certificate;
mod api_compensation;
mod api_design;
mod api_design_jobs;
mod api_diagnose;
mod api_faults;
mod api_held_noise;
mod api_jobs;
mod api_model_check;
mod api_noise;
mod api_product_model;
mod api_upload;
mod calib_accuracy;
mod calib_behaviour;
mod calib_effect_states;
mod calib_grades;
mod calib_raw_units;
mod calib_real_sensors;
mod calib_tactical;
mod calib_time_stamps;
mod cli;
mod cli_diagnose;
mod compensation_round_trip;
mod design_objective;
mod design_search;
mod diagnose_ambiguous;
mod diagnose_clean;
mod diagnose_effects;
mod diagnose_hand_turns;
mod diagnose_nav_turns;
mod diagnose_report;
mod diagnose_unexplained;
mod import_mcap;
mod io_data;
mod model_check;
mod noise_analysis;
mod noise_real_sensors;
mod plan_attitude;
mod process_kill;
mod psins_import;
mod real_xsens;
mod run_store_s3;
mod scale_out;
mod sim_closed_form;
mod sim_hand_turns;
mod sim_real_sensors;
mod strapdown_scheme;
mod thermal_diagnosis;
mod thermal_ramp;
mod thermal_soaked;
