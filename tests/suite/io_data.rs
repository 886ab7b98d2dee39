//! Run data files (SPEC §5): round trips through the writers and readers,
//! rate conversion, gzip detection, and every refusal naming its place.

use std::fs;
use std::io::{self, Read, Write};
use std::path::Path;

use flate2::write::GzEncoder;
use flate2::Compression;
use sinscal_core::io::data::{
    CsvWriter, DataError, DataFormat, F64leWriter, Position, ReadLimits, RecordReader,
    RecordWriter, WriteOptions, RECORD_BYTES,
};
use sinscal_core::record::DataKind;
use sinscal_core::Record;

const RATE_HZ: f64 = 100.0;
const HEADER: &str = "t,dthx,dthy,dthz,dvx,dvy,dvz";

/// Records at 100 Hz with awkward values: non-terminating decimals,
/// subnormals, extremes, negative zero.
fn sample_records(n: usize) -> Vec<Record> {
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    (1..=n)
        .map(|k| {
            let mut r = Record {
                t: k as f64 * 0.01,
                dtheta: [next() * 2e-6, next() * 2e-6, 7.29e-7 + next() * 1e-8],
                dv: [next() * 1e-3, next() * 1e-3, 0.098 + next() * 1e-5],
            };
            match k % 5 {
                0 => r.dtheta[0] = -0.0,
                1 => r.dtheta[1] = 5e-324,
                2 => r.dv[0] = f64::MAX,
                3 => r.dv[1] = 1.0 / 3.0,
                _ => {}
            }
            r
        })
        .collect()
}

fn bits(r: &Record) -> [u64; 7] {
    [
        r.t.to_bits(),
        r.dtheta[0].to_bits(),
        r.dtheta[1].to_bits(),
        r.dtheta[2].to_bits(),
        r.dv[0].to_bits(),
        r.dv[1].to_bits(),
        r.dv[2].to_bits(),
    ]
}

fn assert_bit_exact(read: &[Record], written: &[Record]) {
    assert_eq!(read.len(), written.len(), "record count");
    for (i, (a, b)) in read.iter().zip(written).enumerate() {
        assert_eq!(bits(a), bits(b), "record {} differs: {a:?} vs {b:?}", i + 1);
    }
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = GzEncoder::new(Vec::new(), Compression::default());
    enc.write_all(bytes).expect("compress");
    enc.finish().expect("finish gzip")
}

fn collect<R: Read>(reader: RecordReader<R>) -> Result<Vec<Record>, DataError> {
    reader.collect()
}

fn read_bytes(bytes: &[u8], format: DataFormat) -> Result<Vec<Record>, DataError> {
    read_with(bytes, format, ReadLimits::default())
}

fn read_with(
    bytes: &[u8],
    format: DataFormat,
    limits: ReadLimits,
) -> Result<Vec<Record>, DataError> {
    collect(RecordReader::new(bytes, format, RATE_HZ, limits)?)
}

/// The message of the error that reading `text` as CSV must produce.
fn csv_error(text: &str) -> String {
    match read_bytes(text.as_bytes(), DataFormat::Csv) {
        Ok(records) => panic!("expected an error, read {} records", records.len()),
        Err(e) => e.to_string(),
    }
}

/// A valid increments file of `n` records at 100 Hz, as text.
fn csv_text(n: usize) -> String {
    let mut text = format!("{HEADER}\n");
    for k in 1..=n {
        text.push_str(&format!(
            "{},1e-6,2e-6,3e-6,0.001,0.002,0.098\n",
            k as f64 * 0.01
        ));
    }
    text
}

fn f64le_bytes(records: &[Record]) -> Vec<u8> {
    let mut w = F64leWriter::new(Vec::new());
    for r in records {
        w.write_record(r).expect("write");
    }
    w.finish().expect("finish")
}

fn write_csv(path: &Path, records: &[Record], gzip: bool) {
    let options = WriteOptions {
        gzip,
        comments: vec![
            "unit RLG-0042".into(),
            "written by the io_data tests".into(),
        ],
        temperature_column: false,
    };
    let mut w = CsvWriter::new(fs::File::create(path).expect("create"), &options);
    for r in records {
        w.write_record(r).expect("write");
    }
    w.finish().expect("finish");
}

// ---------------------------------------------------------------- round trips

#[test]
fn csv_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("run.csv");
    let records = sample_records(5000);
    write_csv(&path, &records, false);
    let reader = RecordReader::open(&path, DataFormat::Csv, RATE_HZ).expect("open");
    assert!(!reader.is_gzip());
    assert_eq!(reader.kind(), DataKind::Increments);
    assert_bit_exact(&collect(reader).expect("read"), &records);
}

#[test]
fn gzip_csv_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("run.csv.gz");
    let records = sample_records(5000);
    write_csv(&path, &records, true);
    assert_eq!(&fs::read(&path).expect("read back")[..2], &[0x1f, 0x8b]);
    let reader = RecordReader::open(&path, DataFormat::Csv, RATE_HZ).expect("open");
    assert!(reader.is_gzip());
    assert_bit_exact(&collect(reader).expect("read"), &records);
}

#[test]
fn f64le_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("run.f64");
    let records = sample_records(10_000);
    fs::write(&path, f64le_bytes(&records)).expect("write");
    assert_eq!(
        fs::metadata(&path).expect("stat").len(),
        (records.len() * RECORD_BYTES) as u64
    );
    let reader = RecordReader::open(&path, DataFormat::F64le, RATE_HZ).expect("open");
    assert_eq!(reader.kind(), DataKind::Increments);
    assert_bit_exact(&collect(reader).expect("read"), &records);
}

#[test]
fn record_writer_round_trips_every_format() {
    let dir = tempfile::tempdir().expect("temp dir");
    let records = sample_records(300);
    for (format, gzip) in [
        (DataFormat::Csv, false),
        (DataFormat::Csv, true),
        (DataFormat::F64le, false),
    ] {
        let path = dir.path().join(format!("run-{format}-{gzip}"));
        let options = WriteOptions {
            gzip,
            ..WriteOptions::default()
        };
        let mut w = RecordWriter::create(&path, format, &options).expect("create");
        for r in &records {
            w.write_record(r).expect("write");
        }
        w.finish().expect("finish");
        let reader = RecordReader::open(&path, format, RATE_HZ).expect("open");
        assert_eq!(reader.is_gzip(), gzip);
        assert_bit_exact(&collect(reader).expect("read"), &records);
    }
}

// ------------------------------------------------------------ what is accepted

#[test]
fn rate_files_become_increments_over_each_records_own_interval() {
    // At 200 Hz: the first record over the nominal 5 ms, the second over
    // its step of 5.4 ms (8 % long), the third after a gap over 5 ms.
    let text = "t,wx,wy,wz,fx,fy,fz\n\
                0.005,0.5,-1,2e-3,0,0.25,9.8\n\
                0.0104,1,0,0,-4,0,9.8\n\
                0.1,2,0,0,0,0,9.8\n";
    let mut reader = RecordReader::new(
        text.as_bytes(),
        DataFormat::Csv,
        200.0,
        ReadLimits::default(),
    )
    .expect("header");
    assert_eq!(reader.kind(), DataKind::Rates);
    let expected = [
        (0.005, [0.0025, -0.005, 1e-5], [0.0, 0.00125, 0.049]),
        (0.0104, [0.0054, 0.0, 0.0], [-0.0216, 0.0, 0.05292]),
        (0.1, [0.01, 0.0, 0.0], [0.0, 0.0, 0.049]),
    ];
    for (t, dtheta, dv) in expected {
        let r = reader.next().expect("a record").expect("read");
        assert_eq!(r.t, t);
        for (got, want) in r.dtheta.iter().chain(&r.dv).zip(dtheta.iter().chain(&dv)) {
            assert!(
                (got - want).abs() <= 1e-12 * want.abs(),
                "t = {t}: {got} vs {want}"
            );
        }
    }
    assert!(reader.interval().gap.is_some());
    assert!(reader.next().is_none());
}

#[test]
fn gzip_is_detected_by_magic_bytes_not_by_name() {
    let dir = tempfile::tempdir().expect("temp dir");
    let text = csv_text(50);
    let disguised = dir.path().join("plain-looking.csv");
    fs::write(&disguised, gzip(text.as_bytes())).expect("write");
    let misnamed = dir.path().join("compressed-looking.csv.gz");
    fs::write(&misnamed, &text).expect("write");

    let reader = RecordReader::open(&disguised, DataFormat::Csv, RATE_HZ).expect("open");
    assert!(reader.is_gzip());
    assert_eq!(collect(reader).expect("read").len(), 50);
    let reader = RecordReader::open(&misnamed, DataFormat::Csv, RATE_HZ).expect("open");
    assert!(!reader.is_gzip());
    assert_eq!(collect(reader).expect("read").len(), 50);
}

#[test]
fn concatenated_gzip_members_are_read_to_the_end() {
    let text = csv_text(400);
    let split = text.len() / 2;
    let mut bytes = gzip(&text.as_bytes()[..split]);
    bytes.extend(gzip(&text.as_bytes()[split..]));
    let records = read_bytes(&bytes, DataFormat::Csv).expect("read");
    assert_eq!(records.len(), 400);
    assert_eq!(records[399].t, 4.0);
}

#[test]
fn comments_blank_lines_crlf_bom_and_blanks_are_accepted() {
    let text = "\u{feff}# unit RLG-0042\r\n\
                \r\n\
                  # indented comment\n\
                 t , dthx,dthy ,dthz,dvx,dvy,dvz \r\n\
                0.01, 1e-6 ,2e-6,\t3e-6,0.1,0.2,0.3\r\n\
                # between records\n\
                \n\
                0.02,1,2,3,4,5,6";
    let records = read_bytes(text.as_bytes(), DataFormat::Csv).expect("read");
    assert_eq!(records.len(), 2);
    assert_eq!(records[0].dtheta, [1e-6, 2e-6, 3e-6]);
    assert_eq!(records[1].dv, [4.0, 5.0, 6.0]);
}

#[test]
fn blank_and_comment_lines_count_towards_line_numbers() {
    // Physical line 7 is the bad one.
    let text = format!("# a\n\n{HEADER}\n0.01,0,0,0,0,0,0\n\n# b\n0.02,0,0,0,0,0\n");
    let msg = csv_error(&text);
    assert!(msg.starts_with("line 7:"), "{msg}");
}

#[test]
fn steps_within_ten_percent_are_accepted_and_a_longer_one_is_a_gap_passed_on() {
    // Steps 9.9 % long and short of 10 ms, then 10.1 % long: a gap, and a
    // step of exactly 10 ms at t = 1e4 s after a long one.
    let text = format!(
        "{HEADER}\n0.01,0,0,0,0,0,0\n0.02099,0,0,0,0,0,0\n0.03,0,0,0,0,0,0\n\
         0.04101,0,0,0,0,0,0\n10000.0,0,0,0,0,0,0\n10000.01,0,0,0,0,0,0\n"
    );
    let mut reader = RecordReader::new(
        text.as_bytes(),
        DataFormat::Csv,
        RATE_HZ,
        ReadLimits::default(),
    )
    .expect("header");
    let mut seen = Vec::new();
    while let Some(r) = reader.next() {
        let r = r.expect("read");
        let i = reader.interval();
        seen.push((r.t, i.dt, i.gap.map(|g| (g.t_start, g.length_s()))));
    }
    assert_eq!(reader.gaps(), 2);
    let expected = [
        (0.01, 0.01, None),
        (0.02099, 0.01099, None),
        (0.03, 0.00901, None),
        (0.04101, 0.01, Some((0.03, 0.00101))),
        (10000.0, 0.01, Some((0.04101, 9999.94899))),
        (10000.01, 0.01, None),
    ];
    assert_eq!(seen.len(), expected.len());
    for ((t, dt, gap), (et, edt, egap)) in seen.into_iter().zip(expected) {
        assert_eq!(t, et);
        assert!((dt - edt).abs() < 1e-9, "t = {t}: Δt {dt} vs {edt}");
        match (gap, egap) {
            (None, None) => {}
            (Some((a, l)), Some((ea, el))) => {
                assert_eq!(a, ea);
                assert!((l - el).abs() < 1e-9, "t = {t}: gap {l} vs {el}");
            }
            other => panic!("t = {t}: {other:?}"),
        }
    }
}

#[test]
fn a_run_at_another_rate_than_its_metadata_is_refused() {
    // 104 Hz under 100 Hz metadata: every step 3.8 % short, each normal.
    let text = |rate: f64| {
        let mut text = format!("{HEADER}\n");
        for k in 1..=1500 {
            text.push_str(&format!("{},0,0,0,0,0,0\n", k as f64 / rate));
        }
        text
    };
    let msg = csv_error(&text(104.0));
    assert!(
        msg.starts_with("line 1002: 1000 steps (gaps left out)") && msg.contains("104.0000 Hz"),
        "{msg}"
    );
    // 50 Hz: every step a gap.
    let msg = csv_error(&text(50.0));
    assert!(
        msg.starts_with("line 1002: 1000 of 1000 time steps are more than 10 % longer"),
        "{msg}"
    );
}

#[test]
fn the_longest_allowed_line_passes() {
    let comment = format!("#{}", "x".repeat(ReadLimits::DEFAULT_MAX_LINE_BYTES - 1));
    let text = format!("{comment}\r\n{HEADER}\n0.01,0,0,0,0,0,0\n");
    assert_eq!(
        read_bytes(text.as_bytes(), DataFormat::Csv)
            .expect("read")
            .len(),
        1
    );
}

// ------------------------------------------------------- refusals, with place

#[test]
fn empty_file_is_refused() {
    let msg = csv_error("");
    assert!(
        msg.contains("empty file") && msg.contains("0 lines"),
        "{msg}"
    );
    let msg = csv_error("# only\n\n# comments\n");
    assert!(
        msg.contains("empty file") && msg.contains("3 lines"),
        "{msg}"
    );
    assert!(matches!(
        read_bytes(&gzip(b""), DataFormat::Csv),
        Err(DataError::NoHeader { lines: 0 })
    ));
}

#[test]
fn header_without_records_is_refused() {
    let msg = csv_error(&format!("# c\n{HEADER}\n# nothing follows\n\n"));
    assert!(
        msg.contains("no records") && msg.contains("line 2"),
        "{msg}"
    );
}

#[test]
fn missing_header_is_refused_naming_the_line() {
    let msg = csv_error("# comment\n\n0.01,0,0,0,0,0,0\n0.02,0,0,0,0,0,0\n");
    assert!(msg.starts_with("line 3: missing header"), "{msg}");
}

#[test]
fn unknown_header_is_refused_naming_the_line() {
    let msg = csv_error("# a\n# b\n# c\nt;dthx;dthy;dthz;dvx;dvy;dvz\n0.01,0,0,0,0,0,0\n");
    assert!(msg.starts_with("line 4: unknown header `t;dthx"), "{msg}");
    let msg = csv_error("time,dthx,dthy,dthz,dvx,dvy,dvz\n");
    assert!(msg.starts_with("line 1: unknown header"), "{msg}");
}

/// A file whose 5th line is `bad`.
fn fifth_line(bad: &str) -> String {
    format!(
        "{HEADER}\n0.01,0,0,0,0,0,0\n0.02,0,0,0,0,0,0\n0.03,0,0,0,0,0,0\n{bad}\n0.05,0,0,0,0,0,0\n"
    )
}

#[test]
fn wrong_column_count_is_refused_naming_the_line() {
    let msg = csv_error(&fifth_line("0.04,0,0,0,0,0"));
    assert_eq!(msg, "line 5: expected 7 columns, found 6");
    let msg = csv_error(&fifth_line("0.04,0,0,0,0,0,0,0"));
    assert_eq!(msg, "line 5: expected 7 columns, found 8");
}

#[test]
fn non_numeric_value_is_refused_naming_line_and_column() {
    let msg = csv_error(&fifth_line("0.04,0,abc,0,0,0,0"));
    assert_eq!(msg, "line 5: column 3 (dthy) is not a number: `abc`");
    let msg = csv_error(&fifth_line("0.04,0,0,0,0,0,"));
    assert_eq!(msg, "line 5: column 7 (dvz) is not a number: ``");
    let rates = "t,wx,wy,wz,fx,fy,fz\n0.01,0,0,0,0,0,0\n0.02,0,0,0,1.2.3,0,0\n";
    assert_eq!(
        csv_error(rates),
        "line 3: column 5 (fx) is not a number: `1.2.3`"
    );
}

#[test]
fn nan_and_infinite_values_are_refused_naming_line_and_column() {
    for (bad, column) in [
        ("0.04,nan,0,0,0,0,0", "column 2 (dthx)"),
        ("0.04,0,0,inf,0,0,0", "column 4 (dthz)"),
        ("0.04,0,0,0,-Infinity,0,0", "column 5 (dvx)"),
        ("0.04,0,0,0,0,1e400,0", "column 6 (dvy)"),
        ("NaN,0,0,0,0,0,0", "column 1 (t)"),
    ] {
        let msg = csv_error(&fifth_line(bad));
        assert!(
            msg.starts_with(&format!("line 5: {column} is not finite")),
            "{msg}"
        );
    }
}

#[test]
fn non_increasing_time_is_refused_naming_the_line() {
    let msg = csv_error(&fifth_line("0.03,0,0,0,0,0,0"));
    assert_eq!(msg, "line 5: time 0.03 does not increase (previous 0.03)");
    let msg = csv_error(&fifth_line("0.02,0,0,0,0,0,0"));
    assert!(
        msg.starts_with("line 5: time 0.02 does not increase"),
        "{msg}"
    );
}

#[test]
fn a_step_shorter_than_the_tolerance_zero_or_negative_is_refused_naming_the_line() {
    let msg = csv_error(&fifth_line("0.03899,0,0,0,0,0,0"));
    assert!(msg.starts_with("line 5: time step"), "{msg}");
    assert!(
        msg.contains("10 % shorter") && msg.contains("nominal step 0.01 s"),
        "{msg}"
    );
    let msg = csv_error(&fifth_line("0.03,0,0,0,0,0,0"));
    assert!(
        msg.starts_with("line 5: time 0.03 does not increase"),
        "{msg}"
    );
    let msg = csv_error(&fifth_line("0.025,0,0,0,0,0,0"));
    assert!(
        msg.starts_with("line 5: time 0.025 does not increase"),
        "{msg}"
    );
    // 9.9 % short or long passes (and the step after it, as far off the
    // other way).
    for ok in ["0.03901,0,0,0,0,0,0", "0.04099,0,0,0,0,0,0"] {
        let records = read_bytes(fifth_line(ok).as_bytes(), DataFormat::Csv).expect(ok);
        assert_eq!(records.len(), 5, "{ok}");
    }
}

#[test]
fn bad_sample_rate_is_refused_before_reading() {
    for rate in [0.0, -100.0, f64::NAN, f64::INFINITY] {
        let err = RecordReader::new(
            csv_text(3).as_bytes(),
            DataFormat::Csv,
            rate,
            ReadLimits::default(),
        )
        .expect_err("bad rate");
        assert!(err.to_string().contains("sample rate"), "{err}");
        let err = RecordReader::open("/nonexistent/run.csv", DataFormat::Csv, rate)
            .expect_err("bad rate");
        assert!(matches!(err, DataError::InvalidSampleRate(_)), "{err}");
    }
}

#[test]
fn missing_file_is_refused_naming_the_path() {
    let err =
        RecordReader::open("/nonexistent/run.csv", DataFormat::Csv, RATE_HZ).expect_err("no file");
    assert!(err.to_string().contains("/nonexistent/run.csv"), "{err}");
}

#[test]
fn truncated_gzip_is_refused_naming_the_line_reached() {
    let gz = gzip(csv_text(20_000).as_bytes());
    let cut = &gz[..gz.len() / 2];
    let mut reader =
        RecordReader::new(cut, DataFormat::Csv, RATE_HZ, ReadLimits::default()).expect("header");
    let mut ok = 0u64;
    let err = loop {
        match reader.next() {
            Some(Ok(_)) => ok += 1,
            Some(Err(e)) => break e,
            None => panic!("a truncated stream must not end cleanly"),
        }
    };
    assert!(ok > 1000, "the intact part is read first ({ok} records)");
    // The header is line 1, so the line being read is ok + 2.
    let msg = err.to_string();
    assert_eq!(
        msg,
        format!(
            "line {}: gzip data ends unexpectedly (truncated file)",
            ok + 2
        )
    );
    assert!(reader.next().is_none(), "the reader stops after an error");
}

#[test]
fn gzip_cut_inside_its_trailer_is_refused_as_truncated() {
    let gz = gzip(csv_text(10).as_bytes());
    let msg = read_bytes(&gz[..gz.len() - 3], DataFormat::Csv)
        .expect_err("cut")
        .to_string();
    assert_eq!(msg, "line 12: gzip data ends unexpectedly (truncated file)");
}

#[test]
fn corrupt_gzip_is_refused_naming_the_line_reached() {
    // A wrong checksum is found after the last line (10 records + header).
    let mut gz = gzip(csv_text(10).as_bytes());
    let crc = gz.len() - 8;
    gz[crc] ^= 0xff;
    let msg = read_bytes(&gz, DataFormat::Csv)
        .expect_err("bad crc")
        .to_string();
    assert!(msg.starts_with("line 12: corrupt gzip data"), "{msg}");

    // An unknown compression method is found before the first line.
    let mut gz = gzip(csv_text(10).as_bytes());
    gz[2] = 7;
    let msg = read_bytes(&gz, DataFormat::Csv)
        .expect_err("bad method")
        .to_string();
    assert!(msg.starts_with("line 1: corrupt gzip data"), "{msg}");
}

#[test]
fn f64le_with_trailing_bytes_is_refused_naming_the_record() {
    let mut bytes = f64le_bytes(&sample_records(3));
    bytes.extend_from_slice(&[0; 10]);
    let mut reader = RecordReader::new(
        &bytes[..],
        DataFormat::F64le,
        RATE_HZ,
        ReadLimits::default(),
    )
    .expect("open");
    for _ in 0..3 {
        reader.next().expect("record").expect("valid record");
    }
    let msg = reader
        .next()
        .expect("an error")
        .expect_err("trailing bytes")
        .to_string();
    assert!(
        msg.starts_with("record 4:") && msg.contains("10 trailing bytes"),
        "{msg}"
    );
}

#[test]
fn f64le_bad_values_and_times_are_refused_naming_the_record() {
    let records = sample_records(5);
    let mut nan = records.clone();
    nan[1].dv[2] = f64::NAN;
    let mut inf = records.clone();
    inf[3].t = f64::INFINITY;
    let mut back = records.clone();
    back[2].t = records[0].t;
    let mut jump = records.clone();
    jump[4].t -= 0.00101;
    // The writer refuses non-finite values, so encode them by hand.
    let raw = |rs: &[Record]| -> Vec<u8> {
        rs.iter()
            .flat_map(|r| {
                [
                    r.t,
                    r.dtheta[0],
                    r.dtheta[1],
                    r.dtheta[2],
                    r.dv[0],
                    r.dv[1],
                    r.dv[2],
                ]
                .into_iter()
                .flat_map(f64::to_le_bytes)
            })
            .collect()
    };
    let cases: [(&[Record], &str); 4] = [
        (
            &nan,
            "record 2 (byte offset 56): column 7 (dvz) is not finite: `NaN`",
        ),
        (
            &inf,
            "record 4 (byte offset 168): column 1 (t) is not finite: `inf`",
        ),
        (
            &back,
            "record 3 (byte offset 112): time 0.01 does not increase (previous 0.02)",
        ),
        (&jump, "record 5 (byte offset 224): time step"),
    ];
    for (rs, expected) in cases {
        let msg = read_bytes(&raw(rs), DataFormat::F64le)
            .expect_err("bad")
            .to_string();
        assert!(msg.starts_with(expected), "{msg}");
    }
}

#[test]
fn empty_f64le_file_is_refused() {
    let msg = read_bytes(&[], DataFormat::F64le)
        .expect_err("empty")
        .to_string();
    assert!(msg.contains("empty file"), "{msg}");
}

#[test]
fn f64le_is_never_taken_for_gzip() {
    // The first record's time happens to start with the gzip magic bytes.
    let t = f64::from_le_bytes([0x1f, 0x8b, 0, 0, 0, 0, 0xf0, 0x3f]);
    let record = Record {
        t,
        ..Record::default()
    };
    let bytes = f64le_bytes(&[record]);
    let reader = RecordReader::new(
        &bytes[..],
        DataFormat::F64le,
        RATE_HZ,
        ReadLimits::default(),
    )
    .expect("open");
    assert!(!reader.is_gzip());
    assert_eq!(collect(reader).expect("read")[0].t, t);
}

#[test]
fn gzip_bomb_is_refused_at_the_decompressed_limit() {
    // 64 MiB of comment lines compress to a few tens of kB.
    let mut enc = GzEncoder::new(Vec::new(), Compression::fast());
    let block = "#\n".repeat(1 << 19);
    for _ in 0..64 {
        enc.write_all(block.as_bytes()).expect("compress");
    }
    let bomb = enc.finish().expect("finish");
    assert!(bomb.len() < 1 << 20);
    let limits = ReadLimits {
        max_decompressed_bytes: Some(1 << 20),
        ..ReadLimits::default()
    };
    let err = read_with(&bomb, DataFormat::Csv, limits).expect_err("too large");
    // 2^20 bytes hold 2^19 whole lines; the next one crosses the limit.
    assert_eq!(
        err.to_string(),
        "line 524289: data exceeds the limit of 1048576 bytes (decompressed)"
    );
}

#[test]
fn decompressed_limit_counts_exactly() {
    let text = csv_text(100);
    let exact = ReadLimits {
        max_decompressed_bytes: Some(text.len() as u64),
        ..ReadLimits::default()
    };
    assert_eq!(
        read_with(&gzip(text.as_bytes()), DataFormat::Csv, exact)
            .expect("fits")
            .len(),
        100
    );
    let one_less = ReadLimits {
        max_decompressed_bytes: Some(text.len() as u64 - 1),
        ..ReadLimits::default()
    };
    let msg = read_with(text.as_bytes(), DataFormat::Csv, one_less)
        .expect_err("over")
        .to_string();
    assert!(msg.starts_with("line 101: data exceeds"), "{msg}");

    let bytes = f64le_bytes(&sample_records(10));
    let limits = ReadLimits {
        max_decompressed_bytes: Some(5 * RECORD_BYTES as u64 + 3),
        ..ReadLimits::default()
    };
    let msg = read_with(&bytes, DataFormat::F64le, limits)
        .expect_err("over")
        .to_string();
    assert!(
        msg.starts_with("record 6 (byte offset 280): data exceeds"),
        "{msg}"
    );
}

#[test]
fn overlong_line_is_refused_naming_the_line() {
    let long = "#".repeat(5000);
    let msg = csv_error(&format!("# ok\n{HEADER}\n{long}\n0.01,0,0,0,0,0,0\n"));
    assert_eq!(msg, "line 3: longer than the limit of 4096 bytes");
    // Without any newline at all the reader still stops at the limit.
    let limits = ReadLimits {
        max_line_bytes: 100,
        ..ReadLimits::default()
    };
    let endless = "1".repeat(1_000_000);
    let err = read_with(endless.as_bytes(), DataFormat::Csv, limits).expect_err("too long");
    assert!(
        matches!(
            err,
            DataError::LineTooLong {
                line: 1,
                limit: 100
            }
        ),
        "{err}"
    );
}

/// Gives `data`, then fails the way a dying disk or dropped upload would.
struct FailingAfter<'a> {
    data: &'a [u8],
}

impl Read for FailingAfter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.data.is_empty() {
            return Err(io::Error::other("disk on fire"));
        }
        let n = self.data.len().min(buf.len());
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        Ok(n)
    }
}

#[test]
fn io_errors_are_wrapped_with_the_position() {
    let text = format!("{HEADER}\n0.01,0,0,0,0,0,0\n0.02,0,0,0,0,0,0\n0.0");
    let reader = RecordReader::new(
        FailingAfter {
            data: text.as_bytes(),
        },
        DataFormat::Csv,
        RATE_HZ,
        ReadLimits::default(),
    )
    .expect("header");
    let err = collect(reader).expect_err("io error");
    assert_eq!(err.to_string(), "line 4: read error: disk on fire");
    assert_eq!(err.position(), Some(Position::Line(4)));
    assert!(std::error::Error::source(&err).is_some());

    let bytes = f64le_bytes(&sample_records(2));
    let reader = RecordReader::new(
        FailingAfter { data: &bytes[..70] },
        DataFormat::F64le,
        RATE_HZ,
        ReadLimits::default(),
    )
    .expect("open");
    let err = collect(reader).expect_err("io error");
    assert_eq!(
        err.to_string(),
        "record 2 (byte offset 56): read error: disk on fire"
    );
}

#[test]
fn readers_and_errors_can_move_to_worker_threads() {
    fn send<T: Send + 'static>() {}
    fn send_sync<T: Send + Sync + 'static>() {}
    send::<RecordReader<fs::File>>();
    send::<RecordWriter<fs::File>>();
    send_sync::<DataError>();
}

// ---------------------------------------------------------------- temperature

/// `n` records at 100 Hz with a temperature ramping 0.5 °C/min from 20 °C
/// plus ±0.01 °C of alternating sensor noise.
fn with_temperature(n: usize) -> Vec<(Record, f64)> {
    sample_records(n)
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let noise = if i % 2 == 0 { 0.01 } else { -0.01 };
            let t = r.t;
            (r, 20.0 + 0.5 * t / 60.0 + noise)
        })
        .collect()
}

fn write_with_temperature(format: DataFormat, gzip: bool, rows: &[(Record, f64)]) -> Vec<u8> {
    let options = WriteOptions {
        gzip,
        temperature_column: true,
        ..WriteOptions::default()
    };
    let mut w = RecordWriter::new(Vec::new(), format, &options).expect("writer");
    for (r, c) in rows {
        w.write_record_with_temperature(r, *c).expect("write");
    }
    w.finish().expect("finish")
}

#[test]
fn temperature_column_round_trips_in_csv_gzip_and_f64le() {
    let rows = with_temperature(30_000);
    let records: Vec<Record> = rows.iter().map(|(r, _)| *r).collect();
    for (format, gzip) in [
        (DataFormat::Csv, false),
        (DataFormat::Csv, true),
        (DataFormat::F64le, false),
    ] {
        let bytes = write_with_temperature(format, gzip, &rows);
        let mut reader = RecordReader::new(&bytes[..], format, RATE_HZ, ReadLimits::default())
            .expect("open")
            .with_temperature_column(true);
        assert!(reader.has_temperature());
        let mut read = Vec::new();
        let mut k = 0;
        while let Some(r) = reader.next() {
            read.push(r.expect("record"));
            k += 1;
            if k % 997 == 0 {
                let k = k - 1;
                assert_eq!(reader.temperature_c(), Some(rows[k].1), "{format} {k}");
            }
        }
        assert_bit_exact(&read, &records);
        let s = reader.temperature_summary().expect("summary");
        assert_eq!(s.samples, 30_000);
        assert!((s.mean_c - 21.25).abs() < 1e-3, "{}", s.mean_c);
        // The last record with +0.01 °C of noise is at t = 299.99 s.
        assert!(
            (s.max_c - (20.0 + 0.5 * 299.99 / 60.0 + 0.01)).abs() < 1e-9,
            "{}",
            s.max_c
        );
        let rate = s.max_rate_c_per_min.expect("5 min of run");
        assert!((rate - 0.5).abs() < 1e-6, "{format}: {rate}");
        let history = reader.temperature_history();
        assert_eq!(history.len(), 300);
        assert!((history[100].temp_c - (20.0 + 0.5 * history[100].t_s / 60.0)).abs() < 1e-9);
    }
}

#[test]
fn a_run_without_the_column_has_no_temperature() {
    let bytes = csv_text(10);
    let mut reader = RecordReader::new(
        bytes.as_bytes(),
        DataFormat::Csv,
        RATE_HZ,
        ReadLimits::default(),
    )
    .expect("open")
    // Says nothing for CSV: the header decides.
    .with_temperature_column(true);
    assert!(!reader.has_temperature());
    assert_eq!(reader.by_ref().count(), 10);
    assert_eq!(reader.temperature_summary(), None);
    assert!(reader.temperature_history().is_empty());
    // A rates header with the column.
    let text = "t,wx,wy,wz,fx,fy,fz,temp_c\n0.01,0,0,0,0,0,9.8,25\n0.02,0,0,0,0,0,9.8,25.5\n";
    let mut reader = RecordReader::new(
        text.as_bytes(),
        DataFormat::Csv,
        RATE_HZ,
        ReadLimits::default(),
    )
    .expect("open");
    assert_eq!(reader.by_ref().count(), 2);
    assert_eq!(reader.kind(), DataKind::Rates);
    assert_eq!(reader.temperature_c(), Some(25.5));
}

#[test]
fn f64le_with_the_column_read_without_it_is_refused() {
    // Three 64-byte records read as 56-byte ones: the times do not follow.
    let bytes = write_with_temperature(DataFormat::F64le, false, &with_temperature(3));
    assert!(read_bytes(&bytes, DataFormat::F64le).is_err());
    // Two and a half records.
    let cut = &bytes[..2 * 64 + 32];
    let err = RecordReader::new(cut, DataFormat::F64le, RATE_HZ, ReadLimits::default())
        .unwrap()
        .with_temperature_column(true)
        .collect::<Result<Vec<_>, _>>()
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("32 trailing bytes, not a whole 64-byte record"),
        "{err}"
    );
    assert_eq!(
        err.position(),
        Some(Position::Record {
            number: 3,
            byte_offset: 128
        })
    );
}

#[test]
fn bad_temperatures_are_refused_naming_line_or_record() {
    let header = format!("{HEADER},temp_c\n");
    let line = |t: &str| format!("{header}0.01,0,0,0,0,0,0.098,25\n0.02,0,0,0,0,0,0.098,{t}\n");
    let err = csv_error(&line("nan"));
    assert!(
        err.contains("line 3") && err.contains("8 (temp_c)"),
        "{err}"
    );
    let err = csv_error(&line("250"));
    assert!(
        err.contains("line 3") && err.contains("8 (temp_c)") && err.contains("250"),
        "{err}"
    );
    let err = csv_error(&line("-120.5"));
    assert!(err.contains("line 3") && err.contains("-120.5"), "{err}");
    let err = csv_error(&format!("{header}0.01,0,0,0,0,0,0.098\n"));
    assert!(err.contains("line 2: expected 8 columns, found 7"), "{err}");
    let err = csv_error(&format!("{header}0.01,0,0,0,0,0,0.098,warm\n"));
    assert!(err.contains("line 2") && err.contains("temp_c"), "{err}");
    let err = csv_error(&format!("{HEADER}\n0.01,0,0,0,0,0,0.098,25\n"));
    assert!(err.contains("line 2: expected 7 columns, found 8"), "{err}");

    let mut rows = with_temperature(4);
    rows[2].1 = 1e6;
    // Written by hand: the writer refuses it.
    let mut bytes = Vec::new();
    for (r, c) in &rows {
        for v in [
            r.t,
            r.dtheta[0],
            r.dtheta[1],
            r.dtheta[2],
            r.dv[0],
            r.dv[1],
            r.dv[2],
            *c,
        ] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let err = RecordReader::new(
        &bytes[..],
        DataFormat::F64le,
        RATE_HZ,
        ReadLimits::default(),
    )
    .unwrap()
    .with_temperature_column(true)
    .collect::<Result<Vec<_>, _>>()
    .unwrap_err();
    assert!(
        matches!(err, DataError::Temperature { value, .. } if value == 1e6),
        "{err}"
    );
    assert!(
        err.to_string().contains("record 3 (byte offset 128)"),
        "{err}"
    );
    bytes[3 * 64 - 8..3 * 64].copy_from_slice(&f64::INFINITY.to_le_bytes());
    let err = RecordReader::new(
        &bytes[..],
        DataFormat::F64le,
        RATE_HZ,
        ReadLimits::default(),
    )
    .unwrap()
    .with_temperature_column(true)
    .collect::<Result<Vec<_>, _>>()
    .unwrap_err();
    assert!(matches!(err, DataError::NonFinite { .. }), "{err}");
    assert!(err.to_string().contains("temp_c"), "{err}");
}
