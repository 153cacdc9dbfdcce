//! The reader on what rigs and loggers write, each case against values worked out by hand
//! from the text, and every error against the words it must say.

use super::*;
use crate::recording::{RateUnit, TempUnit, TimeUnit, UnitChoice};

fn read(text: &str, opts: &ReadOptions) -> Result<Axes, RecordingError> {
    parse_axes(text, "rig.txt", opts)
}

fn cols(v: &[&str]) -> Vec<ColumnRef> {
    v.iter().map(|s| s.parse().unwrap()).collect()
}

/// The message of an error, and that it contains every one of `needles`.
fn says(e: RecordingError, needles: &[&str]) -> String {
    let m = e.to_string();
    for n in needles {
        assert!(m.contains(n), "`{m}`\n  lacks `{n}`");
    }
    m
}

fn close(a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len(), "{a:?} vs {b:?}");
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{a:?} vs {b:?}");
    }
}

/// rad/s → °/h: 180/π · 3600.
const RAD_S: f64 = 3600.0 * 180.0 / std::f64::consts::PI;

/// A static MEMS IMU through a chamber cycle as its logger writes it: one tab-separated file,
/// three axes, µs epoch stamps at 2 Hz, rates in rad/s (header suffix), one temperature.
fn imu_text() -> String {
    let mut s = String::from(
        "timestamp (us)\timu.gyro.x [rad/s]\timu.gyro.y [rad/s]\timu.gyro.z [rad/s]\timu.temperature [degC]\n",
    );
    for i in 0..6u64 {
        // Half a second and one extra µs per sample: the µs must survive.
        let t = 1_712_345_678_901_234 + i * 500_001;
        let x = 1.0e-3 + 1e-6 * i as f64;
        s.push_str(&format!(
            "{t}\t{x:.7}\t{:.7}\t{:.7}\t{:.2}\n",
            -x,
            2.0 * x,
            -18.0 + 0.5 * i as f64
        ));
    }
    s
}

#[test]
fn three_axes_in_a_tab_separated_imu_log() {
    let opts = ReadOptions {
        rate_cols: cols(&["imu.gyro.x", "imu.gyro.y", "imu.gyro.z"]),
        ..ReadOptions::default()
    };
    let a = read(&imu_text(), &opts).unwrap();
    let names: Vec<&str> = a.axes.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["imu.gyro.x", "imu.gyro.y", "imu.gyro.z"]);
    let t: Vec<f64> = (0..6).map(|i| f64::from(i * 500_001) / 1e6).collect();
    for (k, sign) in [(0, 1.0), (1, -1.0), (2, 2.0)] {
        let r = &a.axes[k].recording;
        // Exact to the µs: the stamps are subtracted as integers.
        assert_eq!(r.time_s, t);
        let want: Vec<f64> = (0..6)
            .map(|i| sign * (1.0e-3 + 1e-6 * f64::from(i)) * RAD_S)
            .collect();
        close(&r.rate_dph, &want, 1e-6);
        close(
            &r.temp_c,
            &[-18.0, -17.5, -17.0, -16.5, -16.0, -15.5],
            1e-12,
        );
    }
    let notes = a.notes.join("\n");
    for want in [
        "separator: tab (detected",
        "temperature: column `imu.temperature [degC]`",
        "time: column `timestamp (us)`",
        "units from the header: timestamp us, imu.temperature c, imu.gyro.x rad/s",
        "time: the first stamp, 1712345678901234 us (line 2), is subtracted",
    ] {
        assert!(notes.contains(want), "{want} missing in:\n{notes}");
    }
    assert!(a.warnings.is_empty(), "{:?}", a.warnings);
}

/// Without --rate-col the three gyro columns are listed with the header's fields, the
/// separator found and the flag values that choose one; `every_axis` reads all.
#[test]
fn imu_log_without_rate_columns_lists_them_and_the_flag() {
    let m = says(
        read(&imu_text(), &ReadOptions::default()).unwrap_err(),
        &[
            "rig.txt:1:0: several columns could be the rate: `imu.gyro.x [rad/s]`, \
             `imu.gyro.y [rad/s]`, `imu.gyro.z [rad/s]`",
            "fields: timestamp (us), imu.gyro.x [rad/s], imu.gyro.y [rad/s]",
            "separator: tab, detected",
            "choose one with --rate-col imu.gyro.x (or imu.gyro.y, imu.gyro.z: one axis per run)",
        ],
    );
    assert!(!m.contains("--time-col"), "{m}");
    let every = ReadOptions {
        every_axis: true,
        ..ReadOptions::default()
    };
    let a = read(&imu_text(), &every).unwrap();
    let names: Vec<&str> = a.axes.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["imu.gyro.x", "imu.gyro.y", "imu.gyro.z"]);
    close(&a.axes[2].recording.rate_dph[..1], &[2.0e-3 * RAD_S], 1e-9);
}

/// Three temperature columns, one per axis, by number; units by flag.
#[test]
fn one_temperature_per_axis_by_column_number() {
    let text = "t,gx,gy,gz,tx,ty,tz\n0,1,2,3,20,21,22\n1,1.5,2.5,3.5,20.5,21.5,22.5\n";
    let opts = ReadOptions {
        rate_cols: cols(&["2", "3", "4"]),
        temp_cols: cols(&["5", "6", "7"]),
        units: UnitChoice {
            rate: Some(RateUnit::Dps),
            ..UnitChoice::default()
        },
        ..ReadOptions::default()
    };
    let a = read(text, &opts).unwrap();
    assert_eq!(a.axes.len(), 3);
    assert_eq!(a.axes[1].name, "gy");
    assert_eq!(a.axes[1].recording.rate_dph, vec![7200.0, 9000.0]);
    assert_eq!(a.axes[2].recording.temp_c, vec![22.0, 22.5]);
    assert_eq!(a.axes[0].recording.time_s, vec![0.0, 1.0]);
    // Two temperatures for three axes is neither one nor one each.
    let bad = ReadOptions {
        temp_cols: cols(&["5", "6"]),
        ..opts
    };
    says(
        read(text, &bad).unwrap_err(),
        &["--temp-col names 2 columns for 3 rate columns"],
    );
}

/// A logger's export: BOM, CR LF, `;`, decimal commas, a units row, comments before the
/// header and between rows.
#[test]
fn semicolon_decimal_comma_bom_crlf_units_row() {
    let text = "\u{feff}# Logger 7 export\r\ntime_s;rate_dph;temp_c\r\ns;dps;°C\r\n0;-0,0020;20,5\r\n# door opened\r\n0,5;-0,0021;20,6\r\n1,0;-0,0019;20,7\r\n";
    let a = read(text, &ReadOptions::default()).unwrap();
    let r = &a.axes[0].recording;
    assert_eq!(r.time_s, vec![0.0, 0.5, 1.0]);
    close(&r.rate_dph, &[-7.2, -7.56, -6.84], 1e-12);
    assert_eq!(r.temp_c, vec![20.5, 20.6, 20.7]);
    assert_eq!(r.comments, vec![" Logger 7 export", " door opened"]);
    assert_eq!(
        a.notes,
        vec![
            "UTF-8 byte-order mark removed",
            "separator: semicolon (detected; --delimiter sets it)",
            "decimal commas (detected; --decimal-comma false turns them off)",
            "line 3 is a units row, under the header",
            "units from the units row (line 3): time_s s, temp_c c, rate_dph dps",
        ]
    );
}

/// The same export without its units row, read with flags; an error on a later row names the
/// line counted with the comment lines.
#[test]
fn errors_name_the_line_past_comments_and_the_cause() {
    let text = "\u{feff}# x\r\ntime_s;rate_dph;temp_c\r\n0;-7,1;20,5\r\n# y\r\n\r\n1;abc;20,6\r\n";
    says(
        read(text, &ReadOptions::default()).unwrap_err(),
        &["rig.txt:6:2: `rate_dph` is `abc`, expected a number"],
    );
    // Decimal commas not detected (a dot elsewhere): the comma field says so.
    let mixed = "time_s;rate_dph;temp_c\n0;-7.1;20.5\n1;-7,1;20.6\n";
    says(
        read(mixed, &ReadOptions::default()).unwrap_err(),
        &[
            "rig.txt:3:2: `rate_dph` is `-7,1`, expected a number",
            "a decimal comma? give --decimal-comma",
            "separator: semicolon, detected",
        ],
    );
    // A units row two rows down.
    let late = "time_s,rate_dph,temp_c\n0,1,2\ns,dph,C\n";
    says(
        read(late, &ReadOptions::default()).unwrap_err(),
        &["rig.txt:3:1", "only from the row right under the header"],
    );
    // A separator that is not the one given.
    let opts = ReadOptions {
        delimiter: Some(Delimiter::Comma),
        ..ReadOptions::default()
    };
    says(
        read("time_s;rate_dph;temp_c\n0;1;2\n", &opts).unwrap_err(),
        &[
            "no column `time_s`, `rate_dph`, `temp_c`",
            "fields: time_s;rate_dph;temp_c",
            "separator: comma, --delimiter",
        ],
    );
    let m = says(
        read(
            "a,b,c\n0,1;2,3\n",
            &ReadOptions {
                time_col: Some(ColumnRef::Index(1)),
                rate_cols: cols(&["2"]),
                temp_cols: cols(&["3"]),
                ..ReadOptions::default()
            },
        )
        .unwrap_err(),
        &["`b` is `1;2`", "give --delimiter semicolon"],
    );
    assert!(m.starts_with("rig.txt:2:2: "), "{m}");
}

#[test]
fn whitespace_aligned_table() {
    let text = "# bench 3\n  time_s    rate_dph   temp_c\n  0.0      -7.10      25.00\n  1.0      -7.20      25.10\n\t2.0\t  -7.30 \t 25.20  \n";
    let a = read(text, &ReadOptions::default()).unwrap();
    let r = &a.axes[0].recording;
    assert_eq!(r.time_s, vec![0.0, 1.0, 2.0]);
    assert_eq!(r.rate_dph, vec![-7.1, -7.2, -7.3]);
    assert_eq!(
        a.notes,
        vec!["separator: whitespace (detected; --delimiter sets it)"]
    );
    says(
        read(
            "t r T\n0 1 2\n1 2\n",
            &ReadOptions {
                rate_cols: cols(&["r"]),
                temp_cols: cols(&["T"]),
                ..ReadOptions::default()
            },
        )
        .unwrap_err(),
        &[
            "rig.txt:3:0: row has 2 fields, expected 3",
            "separator: whitespace, detected",
        ],
    );
}

/// The format's own file reads exactly as the plain split-and-parse it was written for.
#[test]
fn own_format_reads_as_written() {
    let mut text = String::from("# seed = 1\ntime_s,rate_dph,temp_c,chamber_c,phase\n");
    for i in 0..200 {
        let t = 1000.0 + f64::from(i) * 1.000_001;
        text.push_str(&format!(
            "{t:.6},{:.9},{:.4},{:.4},p{}\n",
            -7.1 + (f64::from(i)).sin() * 1e-3,
            20.0 + 0.01 * f64::from(i),
            15.0 - 0.02 * f64::from(i),
            i % 3
        ));
    }
    let a = read(&text, &ReadOptions::default()).unwrap();
    assert!(a.notes.is_empty(), "{:?}", a.notes);
    let r = &a.axes[0].recording;
    let field = |line: &str, k: usize| line.split(',').nth(k).unwrap().parse::<f64>().unwrap();
    let rows: Vec<&str> = text.lines().skip(2).collect();
    // The clock is kept (no origin subtracted) and every value is the nearest f64.
    assert_eq!(
        r.time_s,
        rows.iter().map(|l| field(l, 0)).collect::<Vec<_>>()
    );
    assert_eq!(
        r.rate_dph,
        rows.iter().map(|l| field(l, 1)).collect::<Vec<_>>()
    );
    assert_eq!(
        r.chamber_c.as_ref().unwrap(),
        &rows.iter().map(|l| field(l, 3)).collect::<Vec<_>>()
    );
    assert_eq!(r.extra[0].0, "phase");
    assert_eq!(r.extra[0].1[4], "p1");
    assert_eq!(r.comments, vec![" seed = 1"]);
    assert_eq!(a.axes[0].name, "rate_dph");
}

/// Units from flags override the header's, with a note; a header unit of the wrong kind is
/// refused with the flag.
#[test]
fn header_units_and_flags() {
    let text = "time [ms],rate (deg/s),temp [K]\n0,0.001,293.15\n1000,0.002,293.25\n";
    let opts = ReadOptions {
        rate_cols: cols(&["rate"]),
        temp_cols: cols(&["temp"]),
        ..ReadOptions::default()
    };
    let a = read(text, &opts).unwrap();
    let r = &a.axes[0].recording;
    assert_eq!(r.time_s, vec![0.0, 1.0]);
    close(&r.rate_dph, &[3.6, 7.2], 1e-12);
    close(&r.temp_c, &[20.0, 20.1], 1e-9);
    let flagged = ReadOptions {
        units: UnitChoice {
            rate: Some(RateUnit::Mdps),
            temp: Some(TempUnit::C),
            time: Some(TimeUnit::Ms),
        },
        ..opts.clone()
    };
    let a = read(text, &flagged).unwrap();
    close(&a.axes[0].recording.rate_dph, &[0.0036, 0.0072], 1e-12);
    let notes = a.notes.join("\n");
    assert!(
        notes.contains("--rate-unit mdps overrides the header's `deg/s` for `rate`"),
        "{notes}"
    );
    assert!(
        notes.contains("--temp-unit c overrides the header's `K` for `temp`"),
        "{notes}"
    );
    assert!(!notes.contains("--time-unit"), "{notes}");
    says(
        read("time,rate [us],temp\n0,1,2\n", &opts).unwrap_err(),
        &[
            "rig.txt:1:2",
            "`rate` is read as a rate column, but its header says `us`",
            "--rate-unit",
        ],
    );
}

/// A column whose unit nobody stated is checked as before, named as in the file, and the
/// suggestion is the unit that fits (µs at 2 Hz: `us`, not `ms`).
#[test]
fn unstated_units_are_checked_under_their_own_names() {
    let mut text = String::from("timestamp\tgyro\ttemperature\n");
    for i in 0..100u64 {
        text.push_str(&format!("{}\t-7.1\t300.0\n", 1_000_000 + i * 500_000));
    }
    let opts = ReadOptions {
        rate_cols: cols(&["gyro"]),
        ..ReadOptions::default()
    };
    let m = says(
        read(&text, &opts).unwrap_err(),
        &[
            "temperature: median 300.00 looks like kelvin",
            "--temp-unit k",
            "timestamp: median step 500000",
            "--time-unit us",
            "gyro: the unit of the rate column is not stated",
        ],
    );
    assert!(!m.contains("--time-unit ms"), "{m}");
    let ok = ReadOptions {
        units: UnitChoice {
            time: Some(TimeUnit::Us),
            temp: Some(TempUnit::K),
            rate: Some(RateUnit::Dph),
        },
        ..opts
    };
    let a = read(&text, &ok).unwrap();
    assert_eq!(a.axes[0].recording.time_s[1], 0.5);
    assert_eq!(a.axes[0].recording.rate_dph[0], -7.1);
}

/// An empty field leaves that sample out of its axis (counted in the notes); NaN is refused.
#[test]
fn empty_fields_are_gaps_and_nan_is_refused() {
    let text =
        "time_s,a,b,temp_c\n0,1,1,20\n1,1,1,20\n2,1,1,20\n3,,1,20\n4,1,1,20\n5,1,1,20\n6,1,1,\n";
    let opts = ReadOptions {
        rate_cols: cols(&["a", "b"]),
        units: UnitChoice {
            rate: Some(RateUnit::Dph),
            ..UnitChoice::default()
        },
        ..ReadOptions::default()
    };
    let a = read(text, &opts).unwrap();
    assert_eq!(a.axes[0].recording.time_s, vec![0.0, 1.0, 2.0, 4.0, 5.0]);
    assert_eq!(
        a.axes[1].recording.time_s,
        vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    );
    let notes = a.notes.join("\n");
    assert!(
        notes.contains(
            "`a`: 2 row(s) with an empty rate, temperature or chamber field left out (first at \
             line 5)"
        ),
        "{notes}"
    );
    assert!(notes.contains("`b`: 1 row(s)"), "{notes}");
    // The gap is axis a's alone, so the warning names it.
    assert_eq!(a.warnings.len(), 1, "{:?}", a.warnings);
    assert!(
        a.warnings[0].starts_with("a: time_s: 1 gap"),
        "{:?}",
        a.warnings
    );
    says(
        read("time_s,rate_dph,temp_c\n0,NaN,1\n", &ReadOptions::default()).unwrap_err(),
        &["rig.txt:2:2", "expected a finite number"],
    );
}

#[test]
fn times_must_increase_and_options_must_agree_with_the_file() {
    says(
        read(
            "timestamp;r;temp\n100;1;2\n200;1;2\n200;1;2\n",
            &ReadOptions {
                rate_cols: cols(&["r"]),
                ..ReadOptions::default()
            },
        )
        .unwrap_err(),
        &["rig.txt:4:1: `timestamp` 200 does not increase (line 3 has 200)"],
    );
    says(
        read(
            "time_s,rate_dph,temp_c\n0,1,2\n",
            &ReadOptions {
                decimal_comma: Some(true),
                ..ReadOptions::default()
            },
        )
        .unwrap_err(),
        &[
            "--decimal-comma: a comma-separated file cannot have decimal commas",
            "--delimiter",
        ],
    );
    says(
        read(
            "time,timestamp,rate_dph,temp_c\n0,0,1,2\n",
            &ReadOptions::default(),
        )
        .unwrap_err(),
        &[
            "several columns could be the time: `time`, `timestamp`",
            "--time-col",
        ],
    );
    says(
        read(
            "time_s,rate_dph,temp_c\n0,1,2\n",
            &ReadOptions {
                rate_cols: cols(&["gyro"]),
                ..ReadOptions::default()
            },
        )
        .unwrap_err(),
        &[
            "--rate-col gyro: no such column",
            "fields: time_s, rate_dph, temp_c",
        ],
    );
    says(
        read(
            "time_s,rate_dph,temp_c\n0,1,2\n",
            &ReadOptions {
                rate_cols: cols(&["9"]),
                ..ReadOptions::default()
            },
        )
        .unwrap_err(),
        &["--rate-col 9: the header has 3 columns"],
    );
    says(
        read(
            "time_s,rate_dph,temp_c\n0,1,2\n",
            &ReadOptions {
                rate_cols: cols(&["1"]),
                ..ReadOptions::default()
            },
        )
        .unwrap_err(),
        &["column `time_s` is read twice"],
    );
    says(
        read("0,1,2\n1,2,3\n", &ReadOptions::default()).unwrap_err(),
        &["the first row holds numbers"],
    );
}

/// A units row whose unit is not one the reader converts is refused with the flag; a flag
/// reads the column anyway.
#[test]
fn unknown_units_in_a_units_row() {
    let text = "time_s\trate_dph\ttemp_c\ns\tLSB\tC\n0\t1\t2\n";
    says(
        read(text, &ReadOptions::default()).unwrap_err(),
        &["rig.txt:2:2", "units row says `LSB`", "--rate-unit"],
    );
    let opts = ReadOptions {
        units: UnitChoice {
            rate: Some(RateUnit::Dph),
            ..UnitChoice::default()
        },
        ..ReadOptions::default()
    };
    let a = read(text, &opts).unwrap();
    assert!(
        a.notes
            .join("\n")
            .contains("overrides the units row's `LSB`"),
        "{:?}",
        a.notes
    );
}

#[test]
fn nanosecond_stamps_keep_their_resolution() {
    let text = "time_ns,rate_dph,temp_c\n1712345678901234567,1,20\n1712345678901234568,1,20\n1712345678902234568,1,20\n";
    let a = read(text, &ReadOptions::default()).unwrap();
    let r = &a.axes[0].recording;
    assert_eq!(r.time_s, vec![0.0, 1e-9, 0.001_000_001]);
    assert!(
        a.notes
            .join("\n")
            .contains("units from the column names: time_ns ns"),
        "{:?}",
        a.notes
    );
}

mod fuzz {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Any text in any of the separators, with units rows, BOMs, decimal commas and
        /// suffixes: a recording or an error, never a panic; what is accepted is well formed.
        #[test]
        fn any_text_reads_or_errs(
            text in "\u{feff}?(time_s|timestamp \\(us\\)|rate_dph|gyro \\[rad/s\\]|temp_c|temperature|x|#|,|;|\t| |\r\n|-?[0-9.,e]{0,5}|NaN|s|dps|°C|\n){0,48}",
            multi in any::<bool>(),
            comma in proptest::option::of(any::<bool>()),
        ) {
            let opts = ReadOptions {
                rate_cols: if multi { cols(&["rate_dph", "2"]) } else { Vec::new() },
                decimal_comma: comma,
                ..ReadOptions::default()
            };
            if let Ok(a) = parse_axes(&text, "fuzz", &opts) {
                prop_assert!(!a.axes.is_empty());
                for ax in &a.axes {
                    let r = &ax.recording;
                    prop_assert!(!r.is_empty());
                    prop_assert!(r.time_s.windows(2).all(|w| w[0] < w[1]));
                    prop_assert!(r.rate_dph.len() == r.len() && r.temp_c.len() == r.len());
                    prop_assert!(r.rate_dph.iter().chain(&r.temp_c).all(|v| v.is_finite()));
                }
            }
        }
    }
}

/// Files as rigs and loggers write them, read from disk through [`read_axes`] and
/// [`Recording::read_checked`] (what the commands call).
mod files {
    use super::*;
    use std::path::PathBuf;

    /// `bytes` written to `name` in a fresh temporary folder, removed when the guard drops.
    fn file(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        (dir, p)
    }

    /// The (line, column, message) of a format error.
    fn located(e: RecordingError) -> (usize, usize, String) {
        match e {
            RecordingError::Format {
                line,
                column,
                message,
                ..
            } => (line, column, message),
            other => panic!("expected a format error, got {other}"),
        }
    }

    /// The units module's factor against the hand value: 180/π · 3600 = 206 264.806 247 °/h
    /// in 1 rad/s (the arcseconds in a radian).
    const ONE_RAD_S_DPH: f64 = 206_264.806_247_096_36;

    /// A three-axis IMU at 2 Hz: µs epoch stamps (the unit in the column's name), rates in
    /// rad/s (header suffixes), the temperature as `temp(degC)`.
    fn imu_file() -> (tempfile::TempDir, PathBuf) {
        let mut s =
            String::from("time_us\tgyro_x [rad/s]\tgyro_y [rad/s]\tgyro_z [rad/s]\ttemp(degC)\n");
        for i in 0..8u32 {
            let t = 1_712_345_678_000_000u64 + 500_000 * u64::from(i);
            let y = -3.5e-5 + 1e-7 * f64::from(i);
            let temp = 25.0 + 0.25 * f64::from(i);
            s.push_str(&format!("{t}\t7.0e-5\t{y:e}\t1\t{temp:.2}\n"));
        }
        file("imu.tsv", s.as_bytes())
    }

    #[test]
    fn three_axis_tab_file_with_epoch_us_and_rad_s() {
        let (_dir, p) = imu_file();
        let opts = ReadOptions {
            rate_cols: cols(&["gyro_x", "gyro_y", "gyro_z"]),
            ..ReadOptions::default()
        };
        let a = read_axes(&p, &opts).unwrap();
        assert_eq!(RateUnit::RadS.to_dph(), ONE_RAD_S_DPH);
        let names: Vec<&str> = a.axes.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(names, ["gyro_x", "gyro_y", "gyro_z"]);
        let t: Vec<f64> = (0..8).map(|i| 0.5 * f64::from(i)).collect();
        let temp: Vec<f64> = (0..8).map(|i| 25.0 + 0.25 * f64::from(i)).collect();
        for ax in &a.axes {
            assert_eq!(ax.recording.time_s, t, "{}", ax.name);
            assert_eq!(ax.recording.temp_c, temp, "{}", ax.name);
            assert!(ax.recording.extra.is_empty(), "{}", ax.name);
        }
        // 7e-5 rad/s is 14.44 °/h, about the Earth rate.
        close(&a.axes[0].recording.rate_dph, &[14.438_536_437; 8], 1e-8);
        let y: Vec<f64> = (0..8)
            .map(|i| (-3.5e-5 + 1e-7 * f64::from(i)) * ONE_RAD_S_DPH)
            .collect();
        close(&a.axes[1].recording.rate_dph, &y, 1e-9);
        assert_eq!(a.axes[2].recording.rate_dph, vec![ONE_RAD_S_DPH; 8]);
        let notes = a.notes.join("\n");
        for want in [
            "separator: tab (detected",
            "temperature: column `temp(degC)`",
            "units from the header: temp c, gyro_x rad/s, gyro_y rad/s, gyro_z rad/s",
            "units from the column names: time_us us",
            "time: the first stamp, 1712345678000000 us (line 2), is subtracted",
        ] {
            assert!(notes.contains(want), "{want} missing in:\n{notes}");
        }
        assert!(a.warnings.is_empty(), "{:?}", a.warnings);
        // Every gyro column without naming them gives the same axes.
        let every = ReadOptions {
            every_axis: true,
            ..ReadOptions::default()
        };
        assert_eq!(read_axes(&p, &every).unwrap().axes, a.axes);
        // One axis by number keeps the other columns as they came.
        let one = ReadOptions {
            rate_cols: cols(&["3"]),
            ..ReadOptions::default()
        };
        let a = read_axes(&p, &one).unwrap();
        let r = &a.axes[0].recording;
        assert_eq!(a.axes[0].name, "gyro_y");
        close(&r.rate_dph, &y, 1e-9);
        assert_eq!(r.extra[0].0, "gyro_x [rad/s]");
        assert_eq!(r.extra[1].1[3], "1");
    }

    /// Without `--rate-col` three gyro columns are ambiguous: the error lists them, the
    /// header's fields and the flag values that choose one.
    #[test]
    fn three_gyro_axes_without_a_rate_column_are_ambiguous() {
        let (_dir, p) = imu_file();
        let e = Recording::read_checked(&p, &UnitChoice::default()).unwrap_err();
        let (line, column, m) = located(e);
        assert_eq!((line, column), (1, 0));
        for want in [
            "several columns could be the rate: `gyro_x [rad/s]`, `gyro_y [rad/s]`, \
             `gyro_z [rad/s]`",
            "fields: time_us, gyro_x [rad/s], gyro_y [rad/s], gyro_z [rad/s], temp(degC)",
            "separator: tab, detected",
            "choose one with --rate-col gyro_x (or gyro_y, gyro_z: one axis per run)",
        ] {
            assert!(m.contains(want), "{want} missing in:\n{m}");
        }
    }

    /// A spreadsheet export: UTF-8 BOM, CR LF, `;` separators, decimal commas, °/s; read
    /// through `read_checked` with no option at all (common names, units from the header).
    #[test]
    fn semicolon_file_with_decimal_commas_bom_and_crlf() {
        let text = "\u{feff}# Prüfstand 2\r\ntime;gyro [deg/s];temp [°C]\r\n\
                    0,0;-0,0020;21,50\r\n0,5;-0,0021;21,55\r\n1,0;-0,0019;21,60\r\n;;\r\n";
        let (_dir, p) = file("export.csv", text.as_bytes());
        let (r, warnings) = Recording::read_checked(&p, &UnitChoice::default()).unwrap();
        assert_eq!(r.time_s, vec![0.0, 0.5, 1.0]);
        // −0.0020 °/s · 3600 = −7.2 °/h.
        close(&r.rate_dph, &[-7.2, -7.56, -6.84], 1e-12);
        assert_eq!(r.temp_c, vec![21.5, 21.55, 21.6]);
        assert_eq!(r.comments, vec![" Prüfstand 2"]);
        assert!(warnings.is_empty(), "{warnings:?}");
        let a = read_axes(&p, &ReadOptions::default()).unwrap();
        let notes = a.notes.join("\n");
        for want in [
            "UTF-8 byte-order mark removed",
            "separator: semicolon (detected",
            "decimal commas (detected",
            "rate: column `gyro [deg/s]`",
            "units from the header: temp c, gyro dps",
        ] {
            assert!(notes.contains(want), "{want} missing in:\n{notes}");
        }
        // Stated, the same file reads the same; dots where commas are said are refused.
        let stated = ReadOptions {
            delimiter: Some(Delimiter::Semicolon),
            decimal_comma: Some(true),
            ..ReadOptions::default()
        };
        assert_eq!(read_axes(&p, &stated).unwrap().axes, a.axes);
        let (_d2, dots) = file("dots.csv", b"time;gyro;temp\n0.0;-7.1;21.5\n");
        let (line, column, m) = located(read_axes(&dots, &stated).unwrap_err());
        assert_eq!((line, column), (2, 1));
        assert!(m.contains("give --decimal-comma false"), "{m}");
    }

    /// An aligned text table: runs of spaces and tabs, the time unit in the column's name,
    /// the rate in mdps and the temperature in °C by suffixes without a space.
    #[test]
    fn whitespace_separated_file() {
        let text = "# bench log\n  timestamp_ms   omega[mdps]\ttemp[degC]\n\
                    1000     -2.0     30.25\n  2000  -2.5  30.50\n3000\t-1.5\t\t30.75\n";
        let (_dir, p) = file("bench.txt", text.as_bytes());
        let (r, _) = Recording::read_checked(&p, &UnitChoice::default()).unwrap();
        assert_eq!(r.time_s, vec![0.0, 1.0, 2.0]);
        // −2 mdps · 3.6 = −7.2 °/h.
        close(&r.rate_dph, &[-7.2, -9.0, -5.4], 1e-12);
        assert_eq!(r.temp_c, vec![30.25, 30.5, 30.75]);
        let notes = read_axes(&p, &ReadOptions::default())
            .unwrap()
            .notes
            .join("\n");
        for want in [
            "separator: whitespace (detected",
            "units from the header: temp c, omega mdps",
            "units from the column names: timestamp_ms ms",
            "the first stamp, 1000 ms (line 3), is subtracted",
        ] {
            assert!(notes.contains(want), "{want} missing in:\n{notes}");
        }
    }

    /// A units row under the header (µs, °/h, kelvin) converts each column; a flag overrides
    /// it for its column, with a note.
    #[test]
    fn units_row_under_the_header() {
        let text = "time,gyro_z,temperature\nus,°/h,K\n\
                    0,-7.10,298.15\n500000,-7.20,298.25\n1000000,-7.15,298.35\n";
        let (_dir, p) = file("units.csv", text.as_bytes());
        let (r, _) = Recording::read_checked(&p, &UnitChoice::default()).unwrap();
        assert_eq!(r.time_s, vec![0.0, 0.5, 1.0]);
        assert_eq!(r.rate_dph, vec![-7.1, -7.2, -7.15]);
        close(&r.temp_c, &[25.0, 25.1, 25.2], 1e-9);
        let a = read_axes(&p, &ReadOptions::default()).unwrap();
        let notes = a.notes.join("\n");
        assert!(notes.contains("line 2 is a units row"), "{notes}");
        assert!(
            notes.contains("units from the units row (line 2): time us, temperature k, gyro_z dph"),
            "{notes}"
        );
        let dps = ReadOptions {
            units: UnitChoice {
                rate: Some(RateUnit::Dps),
                ..UnitChoice::default()
            },
            ..ReadOptions::default()
        };
        let a = read_axes(&p, &dps).unwrap();
        close(
            &a.axes[0].recording.rate_dph,
            &[-25_560.0, -25_920.0, -25_740.0],
            1e-9,
        );
        assert!(
            a.notes
                .join("\n")
                .contains("--rate-unit dps overrides the units row's `°/h`"),
            "{:?}",
            a.notes
        );
    }

    /// A missing column: the error is on the header line and lists what the header holds.
    #[test]
    fn missing_rate_column_lists_the_columns_found() {
        let (_dir, p) = file(
            "accel.csv",
            b"time,accel_x,accel_y,temperature\n0,1,2,20\n1,1,2,20\n",
        );
        let e = Recording::read_checked(&p, &UnitChoice::default()).unwrap_err();
        let path = p.display().to_string();
        assert!(e.to_string().starts_with(&format!("{path}:1:0: ")), "{e}");
        let (line, column, m) = located(e);
        assert_eq!((line, column), (1, 0));
        for want in [
            "no column `rate_dph` in the header",
            "fields: time, accel_x, accel_y, temperature; separator: comma, detected",
            "--rate-col",
        ] {
            assert!(m.contains(want), "{want} missing in:\n{m}");
        }
        assert!(
            !m.contains("--time-col") && !m.contains("--temp-col"),
            "{m}"
        );
    }

    /// NaN or text in a cell is refused with its line (comments counted) and column.
    #[test]
    fn nan_or_text_in_a_cell_names_line_and_column() {
        let opts = ReadOptions {
            rate_cols: cols(&["gx", "gy"]),
            ..ReadOptions::default()
        };
        let head = "# rig 4\ntime_s\tgx\tgy\ttemp_c\n0\t1\t2\t20\n# note\n1\t1\t2\t20\n";
        for (cell, needle) in [
            ("NaN", "`gy` is `NaN`, expected a finite number"),
            ("n/a", "`gy` is `n/a`, expected a number"),
            ("inf", "`gy` is `inf`, expected a finite number"),
        ] {
            let text = format!("{head}2\t1\t{cell}\t20\n");
            let (_dir, p) = file("cells.tsv", text.as_bytes());
            let e = read_axes(&p, &opts).unwrap_err();
            let shown = e.to_string();
            let (line, column, m) = located(e);
            assert_eq!((line, column), (6, 3), "{m}");
            assert!(m.contains(needle), "{needle} missing in:\n{m}");
            assert!(shown.contains("cells.tsv:6:3: "), "{shown}");
        }
    }

    /// An empty file, one with only a byte-order mark and comments, and a header without rows
    /// are each refused with what is missing.
    #[test]
    fn empty_files_are_refused() {
        for (bytes, line, needle) in [
            (&b""[..], 1, "empty file: expected a header row"),
            (
                b"\xEF\xBB\xBF# only a comment\r\n\r\n",
                2,
                "empty file: expected a header row",
            ),
            (
                b"time_s\trate_dph\ttemp_c\n",
                1,
                "no data rows after the header",
            ),
            (
                b"time;gyro;temp\ns;dps;C\n",
                2,
                "no data rows after the header and its units row",
            ),
        ] {
            let (_dir, p) = file("empty.csv", bytes);
            let (l, column, m) = located(read_axes(&p, &ReadOptions::default()).unwrap_err());
            assert_eq!((l, column), (line, 0), "{m}");
            assert!(m.contains(needle), "{needle} missing in:\n{m}");
        }
    }

    /// A column read in the wrong unit is still refused with the flag that converts it: the
    /// format's own file in rad/s and kelvin, and a logger's gyro column in rad/s with no unit
    /// written; stated, the same files read.
    #[test]
    fn unit_mistakes_are_refused_with_the_flag() {
        let mut own = String::from("time_s,rate_dph,temp_c\n");
        let mut imu = String::from("time\tgyro\ttemp\n");
        for i in 0..20 {
            let w = -3.4e-5 + 1e-7 * f64::from(i % 3);
            own.push_str(&format!("{i},{w:e},{:.2}\n", 298.15 + 0.01 * f64::from(i)));
            imu.push_str(&format!("{i}\t{w:e}\t{:.2}\n", 25.0 + 0.01 * f64::from(i)));
        }
        let (_d1, p_own) = file("own.csv", own.as_bytes());
        let (_d2, p_imu) = file("imu.tsv", imu.as_bytes());
        match Recording::read_checked(&p_own, &UnitChoice::default()).unwrap_err() {
            RecordingError::Units { problems, .. } => {
                let m = problems.join("\n");
                for want in [
                    "rate_dph: every value within ±3.4e-5, which looks like rad/s",
                    "--rate-unit rad/s",
                    "temp_c: median 298.25 looks like kelvin",
                    "--temp-unit k",
                ] {
                    assert!(m.contains(want), "{want} missing in:\n{m}");
                }
            }
            other => panic!("expected a units error, got {other}"),
        }
        let e = Recording::read_checked(&p_imu, &UnitChoice::default()).unwrap_err();
        assert!(matches!(e, RecordingError::Units { .. }), "{e}");
        let m = e.to_string();
        assert!(
            m.contains("gyro: every value within") && m.contains("--rate-unit rad/s"),
            "{m}"
        );
        assert!(!m.contains("temp"), "{m}");
        let stated = UnitChoice {
            rate: Some(RateUnit::RadS),
            temp: Some(TempUnit::K),
            time: None,
        };
        let (r, _) = Recording::read_checked(&p_own, &stated).unwrap();
        close(&r.rate_dph[..1], &[-3.4e-5 * RAD_S], 1e-12);
        close(&r.temp_c[..1], &[25.0], 1e-9);
    }

    /// The format's own file reads through `read_checked` exactly as `read_csv` reads it.
    #[test]
    fn own_file_reads_the_same_either_way() {
        let mut text = String::from("# seed 1\ntime_s,rate_dph,temp_c,chamber_c\n");
        for i in 0..50 {
            let x = f64::from(i);
            text.push_str(&format!(
                "{:.6},{:.9},{:.4},{:.4}\n",
                1000.0 + x,
                -7.1 + 1e-3 * x.sin(),
                20.0 + 0.01 * x,
                15.0
            ));
        }
        let (_dir, p) = file("own.csv", text.as_bytes());
        let plain = Recording::read_csv(&p).unwrap();
        let (checked, warnings) = Recording::read_checked(&p, &UnitChoice::default()).unwrap();
        assert_eq!(checked, plain);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(plain.time_s[0], 1000.0);
        assert_eq!(plain.rate_dph[1], "-7.099158529".parse::<f64>().unwrap());
    }
}
