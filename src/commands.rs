//! The glue between the command line and the library: builds the problem from the arguments,
//! runs the chosen driver, prints and writes the reports. Errors are `anyhow` here only.

use crate::cli::*;
use anyhow::{bail, Context, Result};
use gpu_amcs::engine::backend::{make_evaluator, BackendChoice};
use gpu_amcs::engine::{Evaluator, Problem, Reference};
use gpu_amcs::kinematics::{position_deg, preset, RobotModel};
use gpu_amcs::mc::{self, AmcsOptions, IntervalKind, McsOptions, RunSettings, Tolerance};
use gpu_amcs::points::{self, WorkspaceBox};
use gpu_amcs::report::{self, Comparison, RunReport};
use gpu_amcs::simulate::{self, Experiment, Factors, SweepDirection};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

/// Dispatches a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        None => run_amcs(cli.amcs),
        Some(Command::Amcs(a)) => run_amcs(a),
        Some(Command::Mcs(a)) => run_mcs(a),
        Some(Command::Compare(a)) => run_compare(a),
        Some(Command::Model(a)) => run_model(a),
        Some(Command::Points(a)) => run_points(a),
        Some(Command::Fk(a)) => run_fk(a),
        Some(Command::Import(a)) => run_import(a),
        Some(Command::Export(a)) => run_export(a),
        Some(Command::Identify(a)) => run_identify(a),
        Some(Command::Validate(a)) => run_validate(a),
        Some(Command::Simulate(a)) => run_simulate(a),
        Some(Command::Calibrate(a)) => run_calibrate(a),
        Some(Command::Study(a)) => run_study(a),
    }
}

fn load_model(file: &Option<PathBuf>, preset_name: &str) -> Result<RobotModel> {
    Ok(match file {
        Some(p) => RobotModel::from_file(p)?,
        None => preset(preset_name)?,
    })
}

/// Refuses to write an output over an input the user gave.
fn guard_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<()> {
    for o in outputs {
        let oc = std::fs::canonicalize(o).ok();
        for i in inputs {
            if oc.is_some() && oc == std::fs::canonicalize(i).ok() {
                bail!(
                    "output {} is also an input: refusing to overwrite it",
                    o.display()
                );
            }
        }
    }
    Ok(())
}

fn box_of(center: &[f64], size: &[f64]) -> Result<WorkspaceBox> {
    let three = |v: &[f64], flag: &str| -> Result<[f64; 3]> {
        match v {
            [x, y, z] => Ok([*x, *y, *z]),
            _ => bail!("{flag} needs three numbers x,y,z (mm), got {}", v.len()),
        }
    };
    Ok(WorkspaceBox {
        center: three(center, "--box-center")?,
        size: three(size, "--box-size")?,
    })
}

struct Built {
    problem: Problem,
    reference: String,
}

fn build_problem(a: &ProblemArgs) -> Result<Built> {
    if let Some(t) = a.threads {
        if t == 0 {
            bail!("--threads must be at least 1");
        }
        // Only the first call configures the pool; later calls in one process are harmless.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global();
    }
    let model = load_model(&a.model, &a.preset)?;
    let pts = match &a.points_file {
        Some(f) => points::read_csv(f)?,
        None => points::generate(
            &model,
            a.points,
            &box_of(&a.box_center, &a.box_size)?,
            a.points_seed,
        )
        .context("--points")?,
    };
    let reference = match a.reference {
        ReferenceArg::Calibrated => Reference::Calibrated,
        ReferenceArg::Nominal => Reference::Nominal(Box::new(
            load_model(&a.nominal, &a.preset).context("--nominal")?,
        )),
    };
    let label = reference.label(&model);
    let problem = Problem::new(model, &pts, &reference, a.seed).context(match &a.points_file {
        Some(f) => format!("--points-file {}", f.display()),
        None => "test points".into(),
    })?;
    Ok(Built {
        problem,
        reference: label,
    })
}

fn evaluator(a: &ProblemArgs, problem: Problem) -> Result<(Box<dyn Evaluator>, Vec<String>)> {
    let choice = match a.backend {
        BackendArg::Auto => BackendChoice::Auto,
        BackendArg::Gpu => BackendChoice::Gpu,
        BackendArg::Cpu => BackendChoice::Cpu,
    };
    let (ev, note) = make_evaluator(problem, choice, a.adapter.as_deref()).context("--backend")?;
    Ok((ev, note.into_iter().collect()))
}

fn settings(o: &OutputArgs) -> RunSettings {
    RunSettings {
        coverage_probability: o.coverage,
        interval: match o.interval {
            IntervalArg::Shortest => IntervalKind::Shortest,
            IntervalArg::Symmetric => IntervalKind::Symmetric,
        },
        thresholds: o.thresholds.clone(),
        per_point: o.per_point,
    }
}

fn progress_bar(quiet: bool, label: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(0);
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} draws ({elapsed}, eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(label.to_string());
    pb
}

fn inputs_of(a: &ProblemArgs) -> Vec<&Path> {
    [
        a.model.as_deref(),
        a.points_file.as_deref(),
        a.nominal.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect()
}

fn emit(rep: &RunReport, o: &OutputArgs) -> Result<()> {
    if let Some(f) = &o.json {
        report::write_atomic(f, &report::json::render_run(rep))?;
    }
    if let Some(d) = &o.csv {
        report::write_files(d, &report::csv::files(rep))?;
    }
    if let Some(d) = &o.svg {
        report::write_files(d, &report::svg::run_plots(rep))?;
    }
    if !o.quiet {
        print!("{}", report::text::render(rep));
    }
    Ok(())
}

fn check_outputs(a: &ProblemArgs, o: &OutputArgs) -> Result<()> {
    let outs: Vec<&Path> = [o.json.as_deref(), o.csv.as_deref(), o.svg.as_deref()]
        .into_iter()
        .flatten()
        .collect();
    guard_outputs(&inputs_of(a), &outs)
}

/// Builds the problem and evaluator, runs `drive` under a progress bar and writes the reports.
fn run_and_report(
    problem: &ProblemArgs,
    output: &OutputArgs,
    label: &str,
    drive: impl FnOnce(&mut dyn Evaluator, mc::Progress) -> Result<mc::McResult, mc::McError>,
) -> Result<RunReport> {
    check_outputs(problem, output)?;
    let built = build_problem(problem)?;
    let (model, points, seed) = (
        built.problem.model.name.clone(),
        built.problem.n_points(),
        built.problem.seed,
    );
    let (mut ev, notes) = evaluator(problem, built.problem)?;
    let pb = progress_bar(output.quiet, label);
    let cb = |done: u64, total: u64| {
        pb.set_length(total);
        pb.set_position(done);
    };
    let result = drive(ev.as_mut(), &cb)?;
    pb.finish_and_clear();
    let rep = RunReport {
        model,
        points,
        reference: built.reference,
        seed,
        notes,
        result,
    };
    emit(&rep, output)?;
    Ok(rep)
}

fn run_amcs(a: AmcsArgs) -> Result<()> {
    let opts = AmcsOptions {
        tolerance: match a.ndig {
            Some(n) => Tolerance::Ndig(n),
            None => Tolerance::Delta(a.delta),
        },
        batch_size: a.batch,
        max_draws: a.max_draws,
        settings: settings(&a.output),
    };
    opts.check()?;
    let rep = run_and_report(&a.problem, &a.output, "AMCS", |ev, cb| {
        mc::run_amcs(ev, &opts, Some(cb))
    })?;
    if !rep.result.converged {
        eprintln!(
            "warning: AMCS did not converge within --max-draws {}; the results use all draws made",
            a.max_draws
        );
    }
    Ok(())
}

fn run_mcs(a: McsArgs) -> Result<()> {
    let opts = McsOptions {
        draws: a.draws,
        chunk: 100_000.min(a.draws.max(1)),
        settings: settings(&a.output),
    };
    run_and_report(&a.problem, &a.output, "MCS", |ev, cb| {
        mc::run_mcs(ev, &opts, Some(cb))
    })?;
    Ok(())
}

fn run_compare(a: CompareArgs) -> Result<()> {
    let outs: Vec<&Path> = [a.json.as_deref(), a.markdown.as_deref()]
        .into_iter()
        .flatten()
        .collect();
    guard_outputs(&inputs_of(&a.problem), &outs)?;
    let base = RunSettings {
        coverage_probability: a.coverage,
        ..RunSettings::default()
    };
    let amcs_opts: Vec<AmcsOptions> = a
        .deltas
        .iter()
        .map(|&d| AmcsOptions {
            tolerance: Tolerance::Delta(d),
            batch_size: a.batch,
            max_draws: 100_000_000,
            settings: base.clone(),
        })
        .collect();
    for o in &amcs_opts {
        o.check()?;
    }
    let built = build_problem(&a.problem)?;
    let (model, m, seed) = (
        built.problem.model.name.clone(),
        built.problem.n_points(),
        built.problem.seed,
    );
    let (mut ev, _notes) = evaluator(&a.problem, built.problem)?;
    let pb = progress_bar(a.quiet, "MCS");
    let cb = |done: u64, total: u64| {
        pb.set_length(total);
        pb.set_position(done);
    };
    let mcs = mc::run_mcs(
        ev.as_mut(),
        &McsOptions {
            draws: a.draws,
            chunk: 100_000.min(a.draws.max(1)),
            settings: base.clone(),
        },
        Some(&cb),
    )?;
    let mut amcs = Vec::new();
    for (d, o) in a.deltas.iter().zip(&amcs_opts) {
        pb.set_message(format!("AMCS δ={d}"));
        let r = mc::run_amcs(ev.as_mut(), o, Some(&cb))?;
        let mre = report::max_relative_error(&r, &mcs);
        amcs.push((*d, r, mre));
    }
    pb.finish_and_clear();
    let c = Comparison {
        model,
        points: m,
        seed,
        mcs,
        amcs,
    };
    print!("{}", report::text::render_comparison(&c));
    if let Some(f) = &a.json {
        report::write_atomic(f, &report::json::render_comparison(&c))?;
    }
    if let Some(f) = &a.markdown {
        report::write_atomic(f, &report::markdown::render_comparison(&c))?;
    }
    Ok(())
}

fn write_or_print(out: &Option<PathBuf>, text: &str, inputs: &[&Path]) -> Result<()> {
    match out {
        Some(f) => {
            guard_outputs(inputs, &[f])?;
            report::write_atomic(f, text)?;
        }
        None => print!("{text}"),
    }
    Ok(())
}

fn run_model(a: ModelArgs) -> Result<()> {
    if a.list {
        for name in gpu_amcs::kinematics::PRESETS {
            println!("{name:<10} {}", preset(name)?.name);
        }
        return Ok(());
    }
    write_or_print(&a.out, &preset(&a.preset)?.to_toml(), &[])
}

fn run_points(a: PointsArgs) -> Result<()> {
    let model = load_model(&a.model, &a.preset)?;
    let pts = points::generate(
        &model,
        a.n,
        &box_of(&a.box_center, &a.box_size)?,
        a.points_seed,
    )?;
    let inputs: Vec<&Path> = a.model.as_deref().into_iter().collect();
    write_or_print(&a.out, &points::to_csv(&pts), &inputs)
}

fn run_fk(a: FkArgs) -> Result<()> {
    let model = load_model(&a.model, &a.preset)?;
    let pts = points::read_csv(&a.points_file)?;
    let mut s = String::from("q1,q2,q3,q4,q5,q6,x,y,z\n");
    for q in &pts {
        let p = position_deg(&model.params, &model.tool, q);
        let qs: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
        // Shortest representation that reads back to the same f64: full precision.
        s.push_str(&format!("{},{},{},{}\n", qs.join(","), p[0], p[1], p[2]));
    }
    print!("{s}");
    Ok(())
}

fn run_import(a: ImportArgs) -> Result<()> {
    use gpu_amcs::import::{import_file, ImportError, ImportOptions};
    guard_outputs(&[&a.source], &[&a.out])?;
    let opts = ImportOptions {
        base: a.base.clone(),
        tip: a.tip.clone(),
        name: a.name.clone(),
    };
    let imported = import_file(&a.source, &opts).map_err(|e| match e {
        ImportError::Branching { .. } => anyhow::anyhow!("{e} (--tip LINK)"),
        _ => e.into(),
    })?;
    report::write_atomic(&a.out, &imported.to_toml())?;
    println!(
        "imported {} ({}) -> {}: max deviation source vs model {:e} mm over {} configurations",
        a.source.display(),
        imported.format.name(),
        a.out.display(),
        imported.max_deviation_mm,
        imported.configurations
    );
    Ok(())
}

fn run_export(a: ExportArgs) -> Result<()> {
    use gpu_amcs::import::export;
    let model = load_model(&a.model, &a.preset)?;
    let inputs: Vec<&Path> = a.model.as_deref().into_iter().collect();
    let outputs: Vec<&Path> = [a.urdf.as_deref(), a.ur_calibration.as_deref()]
        .into_iter()
        .flatten()
        .collect();
    guard_outputs(&inputs, &outputs)?;
    // Build everything before writing anything.
    let ur = match &a.ur_calibration {
        Some(_) => Some(export::to_ur_calibration(&model).context("--ur-calibration")?),
        None => None,
    };
    if let Some(f) = &a.urdf {
        report::write_atomic(f, &export::to_urdf(&model, a.name.as_deref()))?;
    }
    if let (Some(f), Some(text)) = (&a.ur_calibration, ur) {
        report::write_atomic(f, &text)?;
    }
    Ok(())
}

fn run_identify(a: IdentifyArgs) -> Result<()> {
    use gpu_amcs::identify::{self, CircleFitMethod, IdentifyOptions, NominalPrior};
    let mut inputs: Vec<&Path> = vec![a.sweeps.as_path()];
    inputs.extend(a.nominal.as_deref());
    if let Some(o) = &a.out {
        guard_outputs(&inputs, &[o])?;
    }
    let nominal = load_model(&a.nominal, &a.preset).context("--nominal")?;
    let data = identify::read_sweeps(&a.sweeps)?;
    let opts = IdentifyOptions {
        method: match a.fit {
            FitArg::Commanded => CircleFitMethod::CommandedAngles,
            FitArg::PointCloud => CircleFitMethod::PointCloud,
        },
        nominal_prior: (!a.no_prior).then(NominalPrior::default),
        refine: !a.no_refine,
    };
    let ids = identify::identify(&data, &nominal, &opts)?;
    if a.verbose {
        for id in &ids {
            print!("{}", identify::render_identify_report(&id.report));
            println!();
        }
    } else if !a.quiet {
        print!(
            "{}",
            identify::render_identify_summary(ids.iter().map(|i| &i.report))
        );
    }
    let warnings = identify_warnings(&ids);
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if a.strict && !warnings.is_empty() {
        bail!(
            "--strict: {} implausible result(s) (warnings above); no model written",
            warnings.len()
        );
    }
    let say = |line: String| {
        if !a.quiet {
            println!("{line}");
        }
    };
    let mut model = if ids.len() == 1 {
        let mut m = ids[0].model.clone();
        m.uncertainty = nominal.uncertainty.clone();
        say(
            "note: one run says nothing about the spread: the model file keeps the nominal \
             model's uncertainty; give several runs (a `run` column) to estimate it"
                .into(),
        );
        m
    } else {
        let models: Vec<RobotModel> = ids.iter().map(|i| i.model.clone()).collect();
        let (stats, what) = if a.covariance {
            (identify::correlated_statistics(&models), "full covariance")
        } else {
            (identify::parameter_statistics(&models), "σ")
        };
        say(format!(
            "{} runs: the model file holds the mean parameters and their run-to-run {what}",
            ids.len()
        ));
        stats.context("parameter statistics of the runs")?
    };
    model.name = format!("{} (identified from {})", nominal.name, a.sweeps.display());
    if let Some(o) = &a.out {
        report::write_atomic(o, &model.to_toml())?;
        say(format!("wrote {}", o.display()));
    }
    Ok(())
}

/// The runs' warnings, one line per joint and kind of problem: the first run's message, with the
/// number of runs that share it.
fn identify_warnings(ids: &[gpu_amcs::identify::Identification]) -> Vec<String> {
    use gpu_amcs::identify::IdentifyWarning;
    // One line per joint, kind of warning and parameter.
    let key = |w: &IdentifyWarning| {
        let kind = match w {
            IdentifyWarning::Parameter { kind, .. } => Some(*kind),
            _ => None,
        };
        (w.joint(), std::mem::discriminant(w), kind)
    };
    type Key = (
        usize,
        std::mem::Discriminant<IdentifyWarning>,
        Option<gpu_amcs::kinematics::ParamKind>,
    );
    let mut seen: Vec<(Key, String, usize)> = Vec::new();
    for w in ids.iter().flat_map(|i| &i.report.warnings) {
        match seen.iter_mut().find(|(k, _, _)| *k == key(w)) {
            Some((_, _, n)) => *n += 1,
            None => seen.push((key(w), w.to_string(), 1)),
        }
    }
    seen.sort_by_key(|s| s.0 .0);
    seen.into_iter()
        .map(|(_, text, n)| {
            if n > 1 {
                format!("{text} [{n} of {} runs]", ids.len())
            } else {
                text
            }
        })
        .collect()
}

fn run_validate(a: ValidateArgs) -> Result<()> {
    use gpu_amcs::identify;
    let model = RobotModel::from_file(&a.model)?;
    let nominal = match &a.nominal {
        None => None,
        Some(f) => Some(load_model(f, &a.preset).context("--nominal")?),
    };
    let m = identify::read_measurements(&a.measured)?;
    let v = identify::validate(&model, &m, nominal.as_ref()).map_err(|e| match e {
        // The library names the line; the file is named here.
        identify::IdentifyError::OutsideLimits { .. } => {
            anyhow::anyhow!("{}: {e} of model {}", a.measured.display(), model.name)
        }
        e => e.into(),
    })?;
    print!("{}", identify::render_validation(&v));
    Ok(())
}

fn factors_of(a: &FactorArgs) -> Result<(Experiment, Factors)> {
    let f = Factors {
        runs: a.runs,
        range_fraction: a.range / 100.0,
        step_deg: a.step,
        speed_fraction: a.speed / 100.0,
        direction: match a.start {
            StartArg::NegToPos => SweepDirection::NegToPos,
            StartArg::PosToNeg => SweepDirection::PosToNeg,
        },
    };
    f.check()?;
    let exp = match &a.truth {
        None => Experiment::tx60(a.robot_seed),
        Some(p) => {
            let truth = RobotModel::from_file(p).context("--truth")?;
            let mut nominal = preset("tx60")?;
            if truth.fixed != nominal.fixed {
                bail!(
                    "--truth {}: its fixed d/β pattern differs from the TX60's",
                    p.display()
                );
            }
            nominal.tool = truth.tool;
            Experiment::with_truth(nominal, truth)
        }
    };
    Ok((exp, f))
}

fn run_simulate(a: SimulateArgs) -> Result<()> {
    let inputs: Vec<&Path> = a.factors.truth.as_deref().into_iter().collect();
    let outs: Vec<&Path> = [a.out.as_deref(), a.truth_out.as_deref()]
        .into_iter()
        .flatten()
        .collect();
    guard_outputs(&inputs, &outs)?;
    let (exp, f) = factors_of(&a.factors)?;
    let data = exp.sweeps(&f, a.factors.seed);
    let mut buf = Vec::new();
    gpu_amcs::identify::write_sweeps(&data, &mut buf)?;
    let text = String::from_utf8(buf).context("sweep CSV")?;
    match &a.out {
        Some(o) => {
            report::write_atomic(o, &text)?;
            eprintln!(
                "wrote {} runs × 6 sweeps ({} points) to {}",
                f.runs,
                text.lines().count() - 1,
                o.display()
            );
        }
        None => print!("{text}"),
    }
    if let Some(t) = &a.truth_out {
        report::write_atomic(t, &exp.truth.to_toml())?;
    }
    Ok(())
}

fn run_calibrate(a: CalibrateArgs) -> Result<()> {
    use gpu_amcs::kinematics::ParamKind;
    let inputs: Vec<&Path> = a.factors.truth.as_deref().into_iter().collect();
    if let Some(o) = &a.out {
        guard_outputs(&inputs, &[o])?;
    }
    if a.accuracy_points == 0 {
        bail!("--accuracy-points must be at least 1");
    }
    let (exp, f) = factors_of(&a.factors)?;
    let cal = simulate::calibrate(&exp, &f, a.factors.seed)?;
    let acc = simulate::accuracy_check(
        &exp,
        &cal.independent,
        a.accuracy_points,
        &WorkspaceBox::default(),
        a.factors.seed ^ 0x5eed,
    )?;
    println!(
        "{} runs identified in {:.2} s ({})",
        f.runs, cal.seconds, cal.independent.name
    );
    let sig = cal.independent.uncertainty.sigmas();
    println!("σ of the identified parameters (mm, deg):");
    for j in 0..6 {
        let row: Vec<String> = ParamKind::ALL
            .iter()
            .enumerate()
            .map(|(k, kind)| format!("{} {:.5}", kind.name(), sig[j * 5 + k] / kind.to_internal()))
            .collect();
        println!("  J{}: {}", j + 1, row.join(", "));
    }
    print!("{}", gpu_amcs::identify::render_validation(&acc));
    let model = if a.independent {
        cal.independent
    } else {
        cal.correlated
    };
    if let Some(o) = &a.out {
        report::write_atomic(o, &model.to_toml())?;
        println!("wrote {}", o.display());
    }
    Ok(())
}

fn run_study(a: StudyArgs) -> Result<()> {
    use gpu_amcs::study::{self, Factor, StudySettings};
    let mut s = if a.quick {
        StudySettings::quick()
    } else {
        StudySettings::default()
    };
    if let Some(r) = a.runs {
        s.baseline.runs = r;
    }
    if let Some(n) = a.mcs_draws {
        s.mcs_draws = n;
    }
    if let Some(fs) = &a.factors {
        s.factors = fs
            .iter()
            .map(|n| {
                Factor::ALL
                    .into_iter()
                    .find(|f| f.name().eq_ignore_ascii_case(n.trim()))
                    .ok_or_else(|| {
                        anyhow::anyhow!(
                            "--factors: unknown factor '{n}' (repeatability, range, step, speed, start)"
                        )
                    })
            })
            .collect::<Result<_>>()?;
    }
    s.point_counts = a.points.clone();
    s.deltas = a.deltas.clone();
    s.robot_seed = a.robot_seed;
    s.calibration_seed = a.seed;
    s.backend = match a.backend {
        BackendArg::Auto => BackendChoice::Auto,
        BackendArg::Gpu => BackendChoice::Gpu,
        BackendArg::Cpu => BackendChoice::Cpu,
    };
    s.adapter = a.adapter.clone();
    s.check()?;
    let pb = if a.quiet {
        ProgressBar::hidden()
    } else {
        let pb = ProgressBar::new(0);
        pb.set_style(
            ProgressStyle::with_template("study [{bar:30}] {pos}/{len} ({elapsed}) {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        pb
    };
    let cb = |done: u64, total: u64, msg: &str| {
        pb.set_length(total);
        pb.set_position(done);
        pb.set_message(msg.to_string());
    };
    let result = study::run_study(&s, Some(&cb))?;
    pb.finish_and_clear();
    study::write_outputs(&result, &a.out)?;
    if !a.quiet {
        println!(
            "study finished in {:.1} s: {} levels; wrote {}",
            result.seconds,
            result.levels.len(),
            a.out.display()
        );
    }
    Ok(())
}
