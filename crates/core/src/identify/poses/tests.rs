//! Unit tests of [`super`].
use super::*;
use crate::kinematics::tx60;

const HEAD: &str = "run,q1,q2,q3,q4,q5,q6,x,y,z,sx,sy,sz\n";

#[test]
fn round_trip_with_runs_and_sigmas() {
    let text = format!(
        "{HEAD}a,0,1,2,3,4,5,100.5,200,300,0.01,0.01,0.02\nb,0,1,2,3,4,5,101,200,300,0.01,0.01,0.02\na,5,1,2,3,4,5,100,-20,300,0.01,0.01,0.02\n"
    );
    let d = parse_poses(text.as_bytes(), "t.csv").unwrap();
    assert_eq!(d.runs.len(), 2);
    assert_eq!(d.runs[0].points.len(), 2);
    assert_eq!(d.runs[0].points[1].line, 4);
    assert_eq!(d.runs[0].points[0].sigma_mm, Some([0.01, 0.01, 0.02]));
    let mut out = Vec::new();
    write_poses(&d, &mut out).unwrap();
    let back = parse_poses(out.as_slice(), "o").unwrap();
    type Row = (Joints, [f64; 3], Option<[f64; 3]>);
    let strip = |d: &PoseData| -> Vec<(Option<String>, Vec<Row>)> {
        d.runs
            .iter()
            .map(|r| {
                let pts = r
                    .points
                    .iter()
                    .map(|p| (p.q_deg, p.position_mm, p.sigma_mm))
                    .collect();
                (r.run.clone(), pts)
            })
            .collect()
    };
    assert_eq!(strip(&back), strip(&d));
}

#[test]
fn header_tells_the_formats_apart() {
    let s =
        parse_tracker_data("joint,q1,q2,q3,q4,q5,q6,x,y,z\n1,0,0,0,0,0,0,1,2,3\n", "s").unwrap();
    assert!(matches!(s, TrackerData::Sweeps(_)));
    let p = parse_tracker_data("q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n", "p").unwrap();
    assert!(matches!(p, TrackerData::Poses(_)));
    let e = parse_tracker_data("a,b\n1,2\n", "bad.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.csv") && e.contains("sweeps") && e.contains("poses"),
        "{e}"
    );
}

/// Each bad input ends in one line naming the file, the line and what is wrong.
#[test]
fn bad_rows_name_their_line() {
    let cases = [
        (
            "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n0,0,0,0,0,NaN,1,2,3\n",
            "line 3",
        ),
        (
            "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n0,0,0,0,0,0,1,2\n",
            "line 3",
        ),
        (
            "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n0,0,0,0,0,0,1,2,3\n",
            "repeats line 2",
        ),
        (
            "q1,q2,q3,q4,q5,q6,x,y,z,sx,sy\n0,0,0,0,0,0,1,2,3,1,1\n",
            "'sz'",
        ),
        (
            "q1,q2,q3,q4,q5,q6,x,y,z,sx,sy,sz\n0,0,0,0,0,0,1,2,3,1,0,1\n",
            "sy = 0",
        ),
        ("q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,abc,1,2,3\n", "q6"),
    ];
    for (text, want) in cases {
        let e = parse_tracker_data(text, "f.csv").unwrap_err().to_string();
        assert!(
            e.contains(want) && e.starts_with("f.csv") && !e.contains('\n'),
            "{e}"
        );
    }
}

/// Repeated measurements of a pose are read as rows of one pose; an identical reading is
/// kept where other repeats differ (a coarse resolution), refused as a copy where none do.
#[test]
fn repeats_are_read_and_copies_refused_only_without_them() {
    let text = "q1,q2,q3,q4,q5,q6,x,y,z\n0,1,2,3,4,5,100,200,300\n0,1,2,3,4,5,100.01,200,300\n0,1,2,3,4,5,100,200,300\n";
    let d = parse_poses(text.as_bytes(), "f.csv").unwrap();
    assert_eq!(
        super::super::repeats::pose_groups(&d.runs[0]),
        vec![vec![0, 1, 2]]
    );
    let copy = "q1,q2,q3,q4,q5,q6,x,y,z\n0,1,2,3,4,5,100,200,300\n9,1,2,3,4,5,100,200,300\n0,1,2,3,4,5,100,200,300\n";
    let e = parse_poses(copy.as_bytes(), "f.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 4") && e.contains("repeats line 2"), "{e}");
}

#[test]
fn seven_joint_poses_and_the_joint_count_check() {
    let text = "q1,q2,q3,q4,q5,q6,q7,x,y,z\n0,1,2,3,4,5,6,1000,200,300\n";
    let d = parse_tracker_data(text, "f.csv").unwrap();
    let TrackerData::Poses(p) = &d else {
        panic!("not poses")
    };
    assert_eq!(p.runs[0].points[0].q_deg.len(), 7);
    let mut out = Vec::new();
    write_poses(p, &mut out).unwrap();
    assert_eq!(&parse_poses(out.as_slice(), "o").unwrap(), p);
    let e = check_tracker_data(&d, &tx60(), "f.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("7 joint angles"), "{e}");
    let e = parse_tracker_data("q1,q2,q3,x,y,z\n0,0,0,1,2,3\n", "f.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("'q4'"), "{e}");
}

#[test]
fn limits_and_metres_are_checked() {
    let m = tx60();
    let d = parse_tracker_data(
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1000,200,300\n0,0,0,0,400,0,1000,200,300\n",
        "f.csv",
    )
    .unwrap();
    let e = check_tracker_data(&d, &m, "f.csv").unwrap_err().to_string();
    assert!(e.contains("line 3") && e.contains("q5"), "{e}");
    let d = parse_tracker_data(
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1.2,0.2,0.3\n10,0,0,0,0,0,1.1,0.4,0.3\n",
        "f.csv",
    )
    .unwrap();
    let e = check_tracker_data(&d, &m, "f.csv").unwrap_err().to_string();
    assert!(e.contains("metres") && e.contains("line 2"), "{e}");
}
