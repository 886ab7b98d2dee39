//! Reading speed of run data files, one core.
//!
//! Writes a synthetic 3.3-hour 100 Hz run (1.2 million records, realistic
//! magnitudes) as CSV, gzip CSV and f64le with the crate's own writers, then
//! reads each several times and reports the best throughput.
//!
//! Run with `cargo bench --bench io_read`. `SINSCAL_BENCH_RECORDS` changes
//! the number of records.

use std::fs::{self, File};
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use sinscal_core::io::data::{DataFormat, RecordReader, RecordWriter, WriteOptions};
use sinscal_core::Record;

const RATE_HZ: f64 = 100.0;
const REPETITIONS: usize = 5;

/// A resting unit's increments plus a little noise, so that numbers have as
/// many digits as real ones do.
fn synthetic_records(n: usize) -> impl Iterator<Item = Record> {
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    (1..=n).map(move |k| Record {
        t: k as f64 * 0.01,
        dtheta: [
            3.1e-9 + noise() * 2e-8,
            6.4e-7 + noise() * 2e-8,
            3.4e-7 + noise() * 2e-8,
        ],
        dv: [noise() * 2e-5, noise() * 2e-5, 0.0979 + noise() * 2e-5],
    })
}

fn write_run(path: &Path, format: DataFormat, gzip: bool, n: usize) {
    let options = WriteOptions {
        gzip,
        comments: vec!["synthetic run for the io_read benchmark".into()],
        temperature_column: false,
    };
    let options = if format == DataFormat::F64le {
        WriteOptions::default()
    } else {
        options
    };
    let mut writer = RecordWriter::create(path, format, &options).expect("create run file");
    for record in synthetic_records(n) {
        writer.write_record(&record).expect("write record");
    }
    writer.finish().expect("finish run file");
}

/// Reads the whole file; returns the elapsed time and the records read.
fn read_once(path: &Path, format: DataFormat) -> (Duration, u64) {
    let start = Instant::now();
    let reader = RecordReader::open(path, format, RATE_HZ).expect("open run file");
    let mut count = 0u64;
    let mut sum = 0.0;
    for record in reader {
        let record = record.expect("valid record");
        sum += record.dv[2];
        count += 1;
    }
    black_box(sum);
    (start.elapsed(), count)
}

fn decompressed_len(path: &Path) -> u64 {
    let mut decoder = flate2::read::MultiGzDecoder::new(File::open(path).expect("open"));
    std::io::copy(&mut decoder, &mut std::io::sink()).expect("decompress")
}

fn main() {
    let n: usize = std::env::var("SINSCAL_BENCH_RECORDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_200_000);
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = [
        ("csv", DataFormat::Csv, false, dir.path().join("run.csv")),
        (
            "csv.gz",
            DataFormat::Csv,
            true,
            dir.path().join("run.csv.gz"),
        ),
        (
            "f64le",
            DataFormat::F64le,
            false,
            dir.path().join("run.f64"),
        ),
    ];

    println!(
        "io_read: {n} records ({:.2} h at {RATE_HZ} Hz), best of {REPETITIONS}",
        n as f64 / RATE_HZ / 3600.0
    );
    for (name, format, gzip, path) in &cases {
        let start = Instant::now();
        write_run(path, *format, *gzip, n);
        let file_bytes = fs::metadata(path).expect("stat").len();
        println!(
            "  wrote {name:7} {:8.1} MB in {:.2} s",
            file_bytes as f64 / 1e6,
            start.elapsed().as_secs_f64()
        );
    }

    for (name, format, gzip, path) in &cases {
        let file_bytes = fs::metadata(path).expect("stat").len();
        let data_bytes = if *gzip {
            decompressed_len(path)
        } else {
            file_bytes
        };
        // The first pass also warms the page cache, as for a freshly
        // uploaded run.
        let mut best = Duration::MAX;
        for _ in 0..REPETITIONS {
            let (elapsed, count) = read_once(path, *format);
            assert_eq!(count, n as u64, "{name}: every record read");
            best = best.min(elapsed);
        }
        let secs = best.as_secs_f64();
        print!(
            "  read  {name:7} {:8.3} s  {:8.1} MB/s  {:6.2} M records/s",
            secs,
            data_bytes as f64 / 1e6 / secs,
            n as f64 / 1e6 / secs
        );
        if *gzip {
            print!(
                "  (decompressed text; {:.1} MB/s of gzip file)",
                file_bytes as f64 / 1e6 / secs
            );
        }
        println!();
    }
}
