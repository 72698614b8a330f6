//! Unit tests of the shard selection.

use super::{Shard, ShardFlags};

fn shard(flag: Option<&str>, shards: Option<u64>, vars: &[(&str, &str)]) -> Result<Shard, String> {
    Shard::from_flags_or_env(flag, shards, |name| {
        vars.iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v.to_string())
    })
    .map_err(|e| e.to_string())
}

fn fails_naming(r: Result<Shard, String>, what: &str) {
    match r {
        Err(e) => assert!(e.contains(what), "{e:?} does not name {what}"),
        Ok(s) => panic!("accepted as {s:?}, expected an error naming {what}"),
    }
}

#[test]
fn shard_from_flag_slurm_or_indexed_job() {
    let slurm = [
        ("SLURM_ARRAY_TASK_ID", "5"),
        ("SLURM_ARRAY_TASK_MIN", "1"),
        ("SLURM_ARRAY_TASK_MAX", "7"),
        ("SLURM_ARRAY_TASK_STEP", "2"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
    ];
    assert_eq!(shard(None, None, &slurm), Ok(Shard { k: 2, n: 4 }));
    assert_eq!(shard(None, Some(4), &slurm), Ok(Shard { k: 2, n: 4 }));
    // The explicit flag wins over the environment.
    assert_eq!(shard(Some("1/3"), None, &slurm), Ok(Shard { k: 1, n: 3 }));
    let job = [("JOB_COMPLETION_INDEX", "3")];
    assert_eq!(shard(None, Some(8), &job), Ok(Shard { k: 3, n: 8 }));
    assert_eq!(shard(None, None, &[]), Ok(Shard::WHOLE));
    let plain = [
        ("SLURM_ARRAY_TASK_ID", "0"),
        ("SLURM_ARRAY_TASK_COUNT", "2"),
    ];
    assert_eq!(shard(None, None, &plain), Ok(Shard { k: 0, n: 2 }));
}

#[test]
fn inconsistent_scheduler_variables_name_the_variable() {
    fails_naming(shard(None, Some(4), &[]), "JOB_COMPLETION_INDEX is not set");
    fails_naming(
        shard(None, None, &[("JOB_COMPLETION_INDEX", "1")]),
        "--shards N",
    );
    fails_naming(
        shard(None, Some(2), &[("JOB_COMPLETION_INDEX", "2")]),
        "JOB_COMPLETION_INDEX: shard 2 of 2",
    );
    fails_naming(
        shard(None, None, &[("SLURM_ARRAY_TASK_ID", "1")]),
        "SLURM_ARRAY_TASK_COUNT: not set",
    );
    fails_naming(
        shard(None, None, &[("SLURM_ARRAY_TASK_COUNT", "4")]),
        "SLURM_ARRAY_TASK_ID: not set",
    );
    let task = |id: &'static str, extra: &[(&'static str, &'static str)]| {
        let mut v = vec![("SLURM_ARRAY_TASK_ID", id), ("SLURM_ARRAY_TASK_COUNT", "4")];
        v.extend_from_slice(extra);
        v
    };
    fails_naming(
        shard(None, None, &task("x", &[])),
        "SLURM_ARRAY_TASK_ID: expected",
    );
    fails_naming(
        shard(None, None, &task("0", &[("SLURM_ARRAY_TASK_MIN", "1")])),
        "below SLURM_ARRAY_TASK_MIN",
    );
    fails_naming(
        shard(None, None, &task("4", &[])),
        "SLURM_ARRAY_TASK_ID: shard 4 of 4",
    );
    fails_naming(
        shard(None, None, &task("3", &[("SLURM_ARRAY_TASK_MAX", "9")])),
        "SLURM_ARRAY_TASK_COUNT: 4 tasks",
    );
    fails_naming(
        shard(None, None, &task("3", &[("SLURM_ARRAY_TASK_STEP", "2")])),
        "SLURM_ARRAY_TASK_STEP 2",
    );
    fails_naming(
        shard(None, None, &task("1", &[("SLURM_ARRAY_TASK_STEP", "0")])),
        "SLURM_ARRAY_TASK_STEP: must be",
    );
    fails_naming(shard(None, Some(3), &task("1", &[])), "--shards 3");
    fails_naming(
        shard(None, Some(4), &task("1", &[("JOB_COMPLETION_INDEX", "1")])),
        "JOB_COMPLETION_INDEX: set together",
    );
}
