//! Helpers the integration tests share: running the binary, scratch directories, and the checks
//! of a failed run (exit code 2, one line naming what is wrong, nothing left behind).
//! Helpers shared by the test modules; not every module uses every helper.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The path of the binary under test: `GPU_AMCS_BIN` when set (a test executable carried to
/// another machine beside the binary), else the one cargo built.
pub fn bin_path() -> std::ffi::OsString {
    std::env::var_os("GPU_AMCS_BIN").unwrap_or_else(|| env!("CARGO_BIN_EXE_gpu-amcs").into())
}

/// The binary under test.
pub fn bin() -> Command {
    Command::new(bin_path())
}

/// Runs the binary with `args`.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// Runs the binary with `args`, asserts it succeeded (naming the arguments and its stderr) and
/// returns its stdout.
pub fn run_ok(args: &[&str]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

/// The points of a pose file's first run as the whole-chain fit takes them (no stated σ).
pub fn measured_points(
    data: &gpu_amcs::identify::PoseData,
) -> Vec<gpu_amcs::identify::chain::MeasuredPoint> {
    data.runs[0]
        .points
        .iter()
        .map(|p| gpu_amcs::identify::chain::MeasuredPoint {
            payload_kg: p.payload_kg,
            q_deg: p.q_deg,
            position_mm: p.position_mm,
            sigma_mm: None,
            line: p.line,
            target: 0,
            sides: None,
        })
        .collect()
}

/// A shard file's text with its content checksum recomputed after an edit: what a deliberate
/// forger would do, so that the checks behind the checksum are tested too.
pub fn reseal(text: &str) -> String {
    let t = text.trim_end();
    let at = t.rfind(",\"content_sha256\"").expect("a sealed shard file");
    gpu_amcs::mc::summary::checksum::seal(&format!("{}}}", &t[..at]))
}

/// A shard file's JSON without its content checksum (which differs wherever a timing does).
pub fn without_checksum(mut v: serde_json::Value) -> serde_json::Value {
    v.as_object_mut()
        .expect("a JSON object")
        .remove("content_sha256")
        .expect("a sealed shard file");
    v
}

/// Runs `script` in `sh -c` with `$BIN` set to the binary, in `dir`.
pub fn sh(dir: &Path, script: &str) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(script)
        .env("BIN", bin_path())
        .current_dir(dir)
        .output()
        .unwrap()
}

/// A fresh, empty scratch directory for one test of this process.
pub fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gpu-amcs-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The run's stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The run's stdout as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Every file and directory under `dir`, relative, sorted (hidden temporary files included).
pub fn tree(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, d: &Path, out: &mut Vec<String>) {
        let Ok(rd) = std::fs::read_dir(d) else { return };
        for e in rd.flatten() {
            let p = e.path();
            out.push(p.strip_prefix(base).unwrap().display().to_string());
            if p.is_dir() {
                walk(base, &p, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Asserts a failed run as the README promises: exit code 2, no panic, one stderr line that
/// names `what`.
pub fn assert_fails_naming(o: &Output, what: &str, label: &str) {
    let e = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{label}: exit {:?}: {e}",
        o.status
    );
    assert!(!e.contains("panicked"), "{label} panicked: {e}");
    assert!(
        e.contains(what),
        "{label}: error does not name '{what}': {e}"
    );
    assert_eq!(
        e.trim().lines().count(),
        1,
        "{label}: not a one-line error: {e}"
    );
}

/// Runs `args` and asserts it fails naming `what` ([`assert_fails_naming`]).
pub fn fails_naming(args: &[&str], what: &str) {
    assert_fails_naming(&run(args), what, &format!("{args:?}"));
}

/// Runs `args`, asserts it fails naming `what`, and that `dir` holds exactly what it held before.
pub fn fails_leaving_nothing(dir: &Path, args: &[&str], what: &str) {
    let before = tree(dir);
    fails_naming(args, what);
    assert_eq!(tree(dir), before, "{args:?} left files behind");
}

/// A path inside `dir` as a string argument.
pub fn arg(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().unwrap().to_string()
}

/// Sends signal `sig` (`"TERM"`, `"INT"`) to a running child and waits for its exit.
pub fn signal(child: &mut std::process::Child, sig: &str) -> std::process::ExitStatus {
    let k = Command::new("kill")
        .args([&format!("-{sig}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(k.success(), "kill -{sig} failed");
    child.wait().unwrap()
}

/// Whether a GPU adapter (lavapipe counts) is present for `test`; without one the test is skipped
/// with a note, except under `CI=true`, where a missing adapter is a failure.
pub fn have_adapter(test: &str) -> bool {
    #[cfg(feature = "gpu")]
    if !gpu_amcs::gpu::adapters().is_empty() {
        return true;
    }
    if std::env::var("CI").map(|v| v == "true").unwrap_or(false) {
        panic!("{test}: no Vulkan/Metal/DX12 adapter found and CI=true (install mesa-vulkan-drivers for lavapipe)");
    }
    eprintln!("{test}: skipped, no GPU adapter (set CI=true to make this a failure)");
    false
}

/// Well-formed XML by a small hand parser: every tag closes in order, attributes are quoted,
/// exactly one root `<svg>` element (the SVG figures' structure, without an XML library).
pub fn check_svg(text: &str, name: &str) {
    let mut stack: Vec<String> = Vec::new();
    let mut roots = 0;
    let mut rest = text;
    while let Some(i) = rest.find('<') {
        let after = &rest[i + 1..];
        let j = after
            .find('>')
            .unwrap_or_else(|| panic!("{name}: unclosed '<'"));
        let tag = &after[..j];
        rest = &after[j + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(close) = tag.strip_prefix('/') {
            let open = stack
                .pop()
                .unwrap_or_else(|| panic!("{name}: stray </{close}>"));
            assert_eq!(open, close.trim(), "{name}: </{close}> closes <{open}>");
            continue;
        }
        let self_closing = tag.ends_with('/');
        let body = tag.trim_end_matches('/');
        let tname: String = body.chars().take_while(|c| !c.is_whitespace()).collect();
        assert!(
            !tname.is_empty() && tname.chars().all(|c| c.is_ascii_alphanumeric()),
            "{name}: bad tag name <{tag}>"
        );
        assert_eq!(
            body.matches('"').count() % 2,
            0,
            "{name}: unbalanced quotes in <{tag}>"
        );
        if stack.is_empty() {
            roots += 1;
            assert_eq!(tname, "svg", "{name}: root is not svg");
        }
        if !self_closing {
            stack.push(tname);
        }
    }
    assert!(stack.is_empty(), "{name}: unclosed {stack:?}");
    assert_eq!(roots, 1, "{name}");
}

/// Well-formed SVG ([`check_svg`]) with no non-finite number anywhere.
pub fn check_svg_finite(text: &str, name: &str) {
    check_svg(text, name);
    assert!(
        !text.contains("NaN") && !text.contains("inf"),
        "{name}: non-finite number"
    );
}

/// The largest absolute difference of two equally long slices.
pub fn max_gap(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}
