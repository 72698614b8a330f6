//! Data files as trackers and robot logs export them (`identify --columns`, `--delimiter`):
//! another delimiter, other column names, radians and metres, extra columns and comments give
//! the same identification as the data file written in the tool's own format.

use crate::common::{assert_fails_naming, run, run_ok, stderr, tmpdir};

/// The parameters of an `identify --json` document, as (name, value) pairs.
fn parameters(json: &std::path::Path) -> Vec<(String, f64)> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    v["identify"]["runs"][0]["chain"]["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_string(),
                p["value"].as_f64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn an_exported_log_identifies_like_the_data_file() {
    let d = tmpdir("column-map");
    let p = |f: &str| d.join(f).display().to_string();
    run_ok(&[
        "simulate",
        "--poses",
        "80",
        "--seed",
        "5",
        "--tracker-sigma",
        "0.01",
        "-o",
        &p("own.csv"),
    ]);
    // The same poses as a robot log exports them: semicolons, a time stamp, joints in radians
    // named A1…A6, the target in metres, a comment and a blank line.
    let own = std::fs::read_to_string(p("own.csv")).unwrap();
    let mut log =
        String::from("# exported by the cell controller\n\nt;A1;A2;A3;A4;A5;A6;TX;TY;TZ\n");
    for (k, line) in own.lines().skip(1).enumerate() {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let mut f = vec![format!("{}", 0.5 * k as f64)];
        f.extend(v[..6].iter().map(|a| format!("{}", a.to_radians())));
        f.extend(v[6..9].iter().map(|x| format!("{}", x / 1000.0)));
        log += &(f.join(";") + "\n");
    }
    std::fs::write(p("log.csv"), &log).unwrap();
    let map = "q1=A1:rad,q2=A2:rad,q3=A3:rad,q4=A4:rad,q5=A5:rad,q6=A6:rad,x=TX:m,y=TY:m,z=TZ:m";
    let common = ["--tracker-sigma", "0.01", "--beyond-geometry=off", "-q"];
    let (own_csv, own_toml, own_json) = (p("own.csv"), p("own.toml"), p("own.json"));
    let mut a = vec![
        "identify",
        &own_csv as &str,
        "-o",
        &own_toml,
        "--json",
        &own_json,
    ];
    a.extend(common);
    run_ok(&a);
    let (log_csv, log_toml, log_json) = (p("log.csv"), p("log.toml"), p("log.json"));
    let mut b = vec![
        "identify",
        &log_csv as &str,
        "-o",
        &log_toml,
        "--json",
        &log_json,
    ];
    b.extend(["--columns", map, "--delimiter", ";"]);
    b.extend(common);
    run_ok(&b);
    let (x, y) = (
        parameters(d.join("own.json").as_path()),
        parameters(d.join("log.json").as_path()),
    );
    assert_eq!(x.len(), y.len());
    for ((n, u), (m, v)) in x.iter().zip(&y) {
        assert_eq!(n, m);
        // The unit round trip (degrees → radians → degrees, mm → m → mm) moves the data by
        // a few ulps, and the fit stops where the cost falls by less than 1e-14 of itself: its
        // parameters then lie within about √1e-14 of a σ (here ≥ 1e-4 mm or degrees) of the
        // optimum, far below 1e-6.
        assert!((u - v).abs() <= 1e-6, "{n}: {u} vs {v}");
    }
    // validate reads such a file the same way: the same errors as on the data file.
    let figures = |file: &str, extra: &[&str]| -> String {
        let mut args = vec![
            "validate",
            "--model",
            &own_toml as &str,
            file,
            "--check-draws",
            "0",
        ];
        args.extend(extra);
        run_ok(&args)
    };
    let own_figures = figures(&own_csv, &[]);
    assert!(own_figures.contains("mean"), "{own_figures}");
    assert_eq!(
        figures(&log_csv, &["--columns", map, "--delimiter", ";"]),
        own_figures
    );
    // The model file records the file the user gave (its own checksum).
    let toml = std::fs::read_to_string(&log_toml).unwrap();
    assert!(toml.contains("log.csv"), "{toml}");
    // Without the map the log is no data file; a map naming a column the file lacks, a bad
    // unit or delimiter are refused naming the flag, with nothing written.
    std::fs::remove_file(&log_toml).unwrap();
    let o = run(&[
        "identify",
        &log_csv,
        "-o",
        &log_toml,
        "--delimiter",
        ";",
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    for (flags, flag, want) in [
        (
            vec!["--columns", "q1=B1:rad", "--delimiter", ";"],
            "--columns",
            "'B1'",
        ),
        (
            vec!["--columns", "x=TX:parsec"],
            "--columns",
            "not a unit of x",
        ),
        (
            vec!["--columns", map, "--delimiter", ";;"],
            "--delimiter",
            "one ASCII character",
        ),
        (vec!["--columns", map], "--columns", "line 3"),
    ] {
        let mut args = vec!["identify", &log_csv as &str, "-o", &log_toml, "-q"];
        args.extend(flags.iter().copied());
        let o = run(&args);
        assert_fails_naming(&o, flag, &format!("{flags:?}"));
        assert!(stderr(&o).contains(want), "{flags:?}: {}", stderr(&o));
        assert!(!d.join("log.toml").exists(), "{flags:?}");
    }
}
