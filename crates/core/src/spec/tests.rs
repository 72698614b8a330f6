//! Tests of the problem spec.
use super::*;
use crate::engine::CpuOnly;

/// Dotted paths of the leaves of a JSON value.
fn leaves(v: &serde_json::Value, at: &str, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) if !m.is_empty() => {
            for (k, v) in m {
                let p = if at.is_empty() {
                    k.clone()
                } else {
                    format!("{at}.{k}")
                };
                leaves(v, &p, out);
            }
        }
        _ => out.push(at.to_string()),
    }
}

/// Specs with every variant of every source.
fn variety() -> Vec<ProblemSpec> {
    let base = ProblemSpec::default();
    let tx60 = crate::kinematics::tx60();
    vec![
        base.clone(),
        ProblemSpec {
            points: PointsSource::Generate(GeneratedPoints {
                box_center: Some([1.0, 2.0, 3.0]),
                box_size: Some([4.0, 5.0, 6.0]),
                ..Default::default()
            }),
            reference: ReferenceSource::Nominal(None),
            adapter: Some("x".into()),
            ..base.clone()
        },
        ProblemSpec {
            model: ModelSource::File("m.toml".into()),
            points: PointsSource::File("p.csv".into()),
            reference: ReferenceSource::Nominal(Some(ModelSource::File("n.toml".into()))),
            ..base.clone()
        },
        ProblemSpec {
            model: ModelSource::Model(Box::new(tx60.clone())),
            points: PointsSource::Given(vec![Joints::filled(6, 0.0)]),
            reference: ReferenceSource::Nominal(Some(ModelSource::Model(Box::new(tx60)))),
            ..base
        },
    ]
}

#[test]
fn every_serialized_key_is_a_field_and_every_field_a_key() {
    let mut seen = std::collections::HashSet::new();
    for spec in variety() {
        let v = serde_json::to_value(&spec).unwrap();
        let mut paths = Vec::new();
        leaves(&v, "", &mut paths);
        for p in paths {
            let f = SpecField::at_path(&p).unwrap_or_else(|| panic!("no field for {p}"));
            seen.insert(f);
        }
        // And it comes back.
        let back: ProblemSpec = serde_json::from_value(v).unwrap();
        assert_eq!(back.points, spec.points);
    }
    for f in SpecField::ALL {
        assert!(seen.contains(&f), "{f} is not in any serialized spec");
        assert_eq!(SpecField::at_path(f.path()), Some(f));
    }
    assert_eq!(SpecField::at_path("model.file"), Some(SpecField::Model));
    assert_eq!(
        SpecField::at_path("reference.nominal.preset"),
        Some(SpecField::Nominal)
    );
    assert_eq!(SpecField::at_path("points.generate"), None);
    assert_eq!(SpecField::at_path("seeds"), None);
}

#[test]
fn errors_name_the_field() {
    let field = |s: ProblemSpec| s.build_problem().err().unwrap().field;
    let base = ProblemSpec::default();
    let gen = |g: GeneratedPoints| PointsSource::Generate(g);
    assert_eq!(
        field(ProblemSpec {
            model: ModelSource::Preset("tx90".into()),
            ..base.clone()
        }),
        SpecField::Preset
    );
    assert_eq!(
        field(ProblemSpec {
            model: ModelSource::File("/nonexistent/m.toml".into()),
            ..base.clone()
        }),
        SpecField::Model
    );
    for (g, f) in [
        (
            GeneratedPoints {
                count: 0,
                ..Default::default()
            },
            SpecField::Points,
        ),
        (
            GeneratedPoints {
                count: MAX_POINTS + 1,
                ..Default::default()
            },
            SpecField::Points,
        ),
        (
            GeneratedPoints {
                box_size: Some([0.0, 1.0, 1.0]),
                ..Default::default()
            },
            SpecField::BoxSize,
        ),
        (
            GeneratedPoints {
                box_center: Some([f64::NAN, 1.0, 1.0]),
                ..Default::default()
            },
            SpecField::BoxCenter,
        ),
    ] {
        assert_eq!(
            field(ProblemSpec {
                points: gen(g),
                ..base.clone()
            }),
            f
        );
    }
    let e = ProblemSpec {
        points: PointsSource::Given(vec![
            Joints::filled(6, 0.0),
            [999.0, 0.0, 0.0, 0.0, 0.0, 0.0].into(),
        ]),
        ..base.clone()
    }
    .build_problem()
    .err()
    .unwrap();
    assert_eq!(e.field, SpecField::Configurations);
    assert!(
        e.to_string()
            .starts_with("configurations: test point 2: q1"),
        "{e}"
    );
    assert_eq!(
        field(ProblemSpec {
            points: PointsSource::File("/nonexistent/p.csv".into()),
            ..base.clone()
        }),
        SpecField::PointsFile
    );
    assert_eq!(
        field(ProblemSpec {
            reference: ReferenceSource::Nominal(Some(ModelSource::Preset("tx90".into()))),
            ..base.clone()
        }),
        SpecField::Nominal
    );
    let e = ProblemSpec {
        backend: BackendChoice::Cpu,
        adapter: Some("x".into()),
        ..base.clone()
    }
    .check()
    .unwrap_err();
    assert_eq!(e.field, SpecField::Adapter);
    assert_eq!(
        e.to_string(),
        "adapter: 'x' needs the gpu or auto backend: the CPU backend uses no adapter"
    );
    let e = ProblemSpec {
        backend: BackendChoice::Gpu,
        ..base.clone()
    }
    .build(&CpuOnly)
    .err()
    .unwrap();
    assert_eq!(e.field, SpecField::Backend);
    let e = ProblemSpec {
        adapter: Some("x".into()),
        ..base
    }
    .build(&CpuOnly)
    .err()
    .unwrap();
    assert_eq!(e.field, SpecField::Adapter);
}

#[test]
fn nominal_defaults_to_the_models_preset() {
    let spec = ProblemSpec {
        model: ModelSource::Preset("ur5e".into()),
        reference: ReferenceSource::Nominal(None),
        ..ProblemSpec::default()
    };
    let b = spec.build(&CpuOnly).unwrap();
    assert_eq!(b.reference, "nominal model (Universal Robots UR5e)");
    assert_eq!(b.evaluator.info().backend, "cpu");
    let spec = ProblemSpec {
        model: ModelSource::Model(Box::new(crate::kinematics::tx60())),
        reference: ReferenceSource::Nominal(None),
        ..ProblemSpec::default()
    };
    let b = spec.build_problem().unwrap();
    assert!(
        b.reference.starts_with("nominal model (Staubli TX60)"),
        "{}",
        b.reference
    );
}

/// A model that is no preset (by name) has no nominal model of its own: a nominal reference
/// without one is refused naming the nominal field (not silently the TX60); given one, or for a
/// model named as a preset (a calibrated UR5e), it builds.
#[test]
fn nominal_of_a_model_that_is_no_preset_must_be_given() {
    let mut m = crate::presets::ur5e();
    m.name = "my arm".into();
    let spec = ProblemSpec {
        model: ModelSource::Model(Box::new(m.clone())),
        reference: ReferenceSource::Nominal(None),
        ..ProblemSpec::default()
    };
    let e = spec.build_problem().err().unwrap();
    assert_eq!(e.field, SpecField::Nominal);
    let text = e.to_string();
    assert!(
        text.contains("'my arm'") && text.contains("no nominal model") && !text.contains("--"),
        "{text}"
    );
    let given = ProblemSpec {
        reference: ReferenceSource::Nominal(Some(ModelSource::Preset("ur5e".into()))),
        ..spec.clone()
    };
    assert!(given.build_problem().is_ok());
    let mut cal = crate::presets::ur5e();
    cal.params[7] += 0.2;
    let named = ProblemSpec {
        model: ModelSource::Model(Box::new(cal)),
        ..spec
    };
    let b = named.build_problem().unwrap();
    assert!(
        b.reference
            .starts_with("nominal model (Universal Robots UR5e)"),
        "{}",
        b.reference
    );
}

/// A nominal model with another number of joints than the model is another robot: refused
/// naming the nominal field, both sources and both counts, either way round (one joint more
/// used to panic in the forward kinematics, one fewer gave a meaningless w). Problem::new
/// refuses it too.
#[test]
fn nominal_with_another_joint_count_is_refused() {
    let seven = crate::presets::iiwa14();
    for (model, nominal) in [("iiwa14", "ur5e"), ("ur5e", "iiwa14")] {
        let spec = ProblemSpec {
            model: ModelSource::Preset(model.into()),
            reference: ReferenceSource::Nominal(Some(ModelSource::Preset(nominal.into()))),
            ..ProblemSpec::default()
        };
        let e = spec.build_problem().err().unwrap();
        assert_eq!(e.field, SpecField::Nominal);
        let (nj, mj) = if model == "ur5e" { (7, 6) } else { (6, 7) };
        assert!(
            matches!(&e.kind, SpecErrorKind::NominalJoints { nominal: n, nominal_joints, model: m, model_joints }
                if *n == format!("preset {nominal}") && *m == format!("preset {model}")
                    && *nominal_joints == nj && *model_joints == mj),
            "{e:?}"
        );
        assert!(!e.to_string().contains("--"), "{e}");
    }
    let points = [seven.joints_at(0.0)];
    let e = crate::engine::Problem::new(
        seven,
        &points,
        &crate::engine::Reference::Nominal(Box::new(crate::presets::ur5e())),
        1,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            crate::engine::ProblemError::NominalJoints {
                nominal_joints: 6,
                model_joints: 7,
                ..
            }
        ),
        "{e:?}"
    );
}
