//! Shards of a sensitivity analysis ([`SensitivityShard`]): the model outputs of a range of base
//! samples, merged into the analysis of the whole run ([`merge_sensitivity`]).

use super::provenance::{in_draw_order, Provenance};
use super::SummaryError;
use crate::engine::{BackendInfo, Evaluator, Problem};
use crate::mc::sensitivity::{
    self, Design, Outputs, SensitivityError, SensitivityOptions, SensitivityResult,
};
use serde::{Deserialize, Serialize};

/// A shard of a sensitivity analysis (`docs/METHOD.md §11`): the model outputs of base samples
/// `[first, end)` (the provenance's range; its `draws` are the base samples N). The bootstrap
/// resamples base samples from the whole range, so shards keep their outputs (8 bytes ×
/// (2 + S) a base sample) and the merge analyses them together, exactly as one run would.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensitivityShard {
    /// Always [`SensitivityShard::KIND`]: tells a sensitivity shard from a run summary.
    pub kind: String,
    /// Where the base samples come from.
    pub provenance: Provenance,
    /// Bootstrap resamples of the analysis.
    pub bootstrap: usize,
    /// Seed of the bootstrap resampling.
    pub bootstrap_seed: u64,
    /// Thresholds of the exceedance indicators, mm.
    pub thresholds: Vec<f64>,
    /// The inputs.
    pub design: Design,
    /// Backend that evaluated the outputs: backend, adapter, driver.
    pub backend: [String; 3],
    /// The outputs of the shard's base samples, written as the bits of each f64 (a JSON
    /// number need not read back to the same f64; the bits do, so the merge is exact).
    #[serde(with = "output_bits")]
    pub outputs: Outputs,
}

/// [`Outputs`] as the IEEE-754 bits of its values.
mod output_bits {
    use super::Outputs;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize, Deserialize)]
    struct Bits {
        a: Vec<u64>,
        b: Vec<u64>,
        sets: Vec<Vec<u64>>,
    }

    fn to_bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn from_bits(v: Vec<u64>) -> Vec<f64> {
        v.into_iter().map(f64::from_bits).collect()
    }

    pub fn serialize<S: Serializer>(o: &Outputs, s: S) -> Result<S::Ok, S::Error> {
        Bits {
            a: to_bits(&o.a),
            b: to_bits(&o.b),
            sets: o.sets.iter().map(|v| to_bits(v)).collect(),
        }
        .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Outputs, D::Error> {
        let b = Bits::deserialize(d)?;
        Ok(Outputs {
            a: from_bits(b.a),
            b: from_bits(b.b),
            sets: b.sets.into_iter().map(from_bits).collect(),
        })
    }
}

impl SensitivityShard {
    /// The `kind` of a sensitivity shard.
    pub const KIND: &'static str = "sensitivity shard";

    /// Evaluates base samples `[provenance.first, provenance.end)` of the analysis of
    /// `problem` with `opts` (`opts.draws` the provenance's draws).
    ///
    /// # Errors
    ///
    /// As [`sensitivity::run_outputs`]: an option out of range, an evaluator of another problem, no
    /// free parameter, a base-sample range that is empty or beyond `opts.draws`, a failing
    /// evaluator, or an output that is not finite.
    pub fn run(
        problem: &Problem,
        ev: &mut dyn Evaluator,
        opts: &SensitivityOptions,
        provenance: Provenance,
    ) -> Result<SensitivityShard, SensitivityError> {
        let range = provenance.first as usize..provenance.end as usize;
        let (outputs, design) = sensitivity::run_outputs(problem, ev, opts, range)?;
        let info = ev.info();
        Ok(SensitivityShard {
            kind: Self::KIND.to_string(),
            provenance,
            bootstrap: opts.bootstrap,
            bootstrap_seed: opts.bootstrap_seed,
            thresholds: opts.thresholds.clone(),
            design,
            backend: [info.backend, info.adapter, info.driver],
            outputs,
        })
    }

    /// The shard as JSON (`kind` first, so a reader can tell it from a summary).
    pub fn to_json(&self) -> String {
        // Plain data with finite floats: serialising cannot fail.
        super::checksum::seal(&serde_json::to_string(self).unwrap_or_default())
    }

    /// Reads a shard written by [`SensitivityShard::to_json`]; `file` names it in errors.
    ///
    /// # Errors
    ///
    /// [`SummaryError::Corrupt`] when `text` is not the JSON of a sensitivity shard, or its kind,
    /// draw range or outputs (count, finiteness) are inconsistent; the message names the field.
    pub fn from_json(text: &str, file: &str) -> Result<SensitivityShard, SummaryError> {
        let corrupt = |message: String| SummaryError::Corrupt {
            file: file.to_string(),
            message,
        };
        let text = super::checksum::verify(text, file)?;
        let s: SensitivityShard =
            serde_json::from_str(&text).map_err(|e| corrupt(e.to_string()))?;
        let p = &s.provenance;
        let n = (p.end - p.first) as usize;
        let o = &s.outputs;
        let checks = [
            (s.kind == Self::KIND, "kind"),
            (p.first < p.end && p.end <= p.draws, "provenance draw range"),
            (o.a.len() == n && o.b.len() == n, "outputs"),
            (o.sets.iter().all(|v| v.len() == n), "outputs"),
            (
                o.a.iter()
                    .chain(&o.b)
                    .chain(o.sets.iter().flatten())
                    .all(|v| v.is_finite()),
                "outputs",
            ),
        ];
        if let Some((_, field)) = checks.iter().find(|(ok, _)| !ok) {
            return Err(corrupt(format!("field `{field}` is inconsistent")));
        }
        Ok(s)
    }
}

/// Errors of merging sensitivity shards: the shards' own, or the analysis's.
#[derive(Debug, thiserror::Error)]
pub enum SensitivityMergeError {
    /// The shards do not make one analysis.
    #[error(transparent)]
    Shards(#[from] SummaryError),
    /// The analysis of the merged outputs failed.
    #[error(transparent)]
    Analysis(#[from] SensitivityError),
}

/// The analysis of named sensitivity shards that together hold every base sample of one run
/// once (checked as [`merge`](super::merge) checks summaries): the same result as one run, to the bit.
///
/// # Errors
///
/// [`SensitivityMergeError::Shards`] when the shards do not make one analysis (none given, a
/// differing field, overlapping or missing base samples; see [`merge`](super::merge)), and
/// [`SensitivityMergeError::Analysis`] when the analysis of the merged outputs fails.
pub fn merge_sensitivity(
    named: &[(String, SensitivityShard)],
) -> Result<SensitivityResult, SensitivityMergeError> {
    let order = in_draw_order(
        named,
        |s| &s.provenance,
        |s| {
            vec![
                ("bootstrap", s.bootstrap.to_string()),
                ("bootstrap_seed", s.bootstrap_seed.to_string()),
                ("thresholds", format!("{:?}", s.thresholds)),
                ("design", format!("{:?}", s.design)),
                (
                    "outputs",
                    format!("{} pick-freeze sets", s.outputs.sets.len()),
                ),
            ]
        },
    )?;
    let first = order[0].1;
    let mut out = Outputs {
        sets: vec![Vec::new(); first.outputs.sets.len()],
        ..Outputs::default()
    };
    for (_, s) in &order {
        out.a.extend_from_slice(&s.outputs.a);
        out.b.extend_from_slice(&s.outputs.b);
        for (all, part) in out.sets.iter_mut().zip(&s.outputs.sets) {
            all.extend_from_slice(part);
        }
    }
    let p = &first.provenance;
    let opts = SensitivityOptions {
        draws: p.draws as usize,
        bootstrap: first.bootstrap,
        bootstrap_seed: first.bootstrap_seed,
        thresholds: first.thresholds.clone(),
        ..SensitivityOptions::default()
    };
    let [backend, adapter, driver] = super::merged_backend(named.iter().map(|(_, s)| &s.backend));
    let info = BackendInfo {
        backend,
        adapter,
        driver,
    };
    let model = (p.model.clone(), p.points, p.seed);
    Ok(first.design.result(model, info, &out, &opts)?)
}
