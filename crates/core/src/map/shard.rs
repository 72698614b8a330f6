//! Shards of a map (docs/METHOD.md §15): a map too large or too slow for one process is split by
//! cell. Every shard solves the inverse kinematics of the whole grid (the serpentine seeding
//! makes a cell's configuration depend on the cells before it, and the solve is cheap beside the
//! evaluation), then evaluates only reached cells `[K·r/N, (K+1)·r/N)` of the `r` reached ones,
//! at the same draws `0 … draws − 1` as every other shard. It keeps its cells' configurations
//! and statistics ([`CellStats`], computed as one run computes them) and `w` over its cells for
//! every draw. The merge takes the elementwise maximum of the shards' `w` (the `w` of all
//! reached cells, since a maximum does not depend on how the cells are grouped) and computes the
//! multi-point statistics with the function one run uses ([`Evaluation::new`]): the merged map
//! equals one run's, bit for bit.
//!
//! A shard file is JSON whose floats are written twice: as numbers (readable) and as the IEEE-754
//! bits of every float in the order they appear (`float_bits`), because a JSON number need not
//! read back to the same f64; the reader restores each float from its bits and refuses a file
//! whose numbers and bits disagree. `w` is stored as bits only (`w_bits`, one hex string).

use super::{CellErrors, CellIk, CellStats, Evaluation, MapResult, MapSpec, Timings, MAX_CELLS};
use crate::engine::BackendInfo;
use crate::mc::summary::{in_range_order, provenance_fields, Fnv, Provenance, SummaryError};
use serde::{Deserialize, Serialize};
use serde_json::{Number, Value};

/// One reached cell of a shard.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardCell {
    /// Index of the cell in the grid's index order ([`MapSpec::targets`]).
    pub cell: usize,
    /// Its configuration.
    pub ik: CellIk,
    /// Its statistics over the draws.
    pub stats: CellStats,
}

/// A shard of a map: reached cells `[first, end)` of all draws.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapShard {
    /// Always [`MapShard::KIND`]: tells a map shard from other shard files.
    pub kind: String,
    /// The whole map's problem: its test points are the configurations of all reached cells
    /// (so `points` is the number reached and `points_hash` fingerprints them), its range all
    /// draws.
    pub provenance: Provenance,
    /// This shard: K and N (K from 0).
    pub shard: [u64; 2],
    /// The origin of the robot's base frame in the description's frame, mm (absent from
    /// shards of versions before it: the origin).
    #[serde(default)]
    pub base_origin_mm: [f64; 3],
    /// What the map asks for.
    pub spec: MapSpec,
    /// Thresholds l_c, mm.
    pub thresholds: Vec<f64>,
    /// FNV-1a hash of the grid indices of all reached cells, hex.
    pub reached_hash: String,
    /// First reached cell of this shard (counting reached cells only).
    pub first: usize,
    /// One past the last reached cell of this shard.
    pub end: usize,
    /// Backend that evaluated the cells: backend, adapter, driver.
    pub backend: [String; 3],
    /// Wall-clock seconds: the inverse kinematics of the whole grid, the evaluation of this
    /// shard's cells.
    pub timings: Timings,
    /// This shard's cells, in grid order.
    pub cells: Vec<ShardCell>,
    /// `w = max_j e_j` over this shard's cells of every draw, written as one string of the
    /// IEEE-754 bits of each value (16 hex digits a draw).
    #[serde(with = "hex_bits")]
    pub w_bits: Vec<f64>,
}

/// Values as one string of 16 hex digits (the IEEE-754 bits) each: exact, and a single JSON
/// value however many draws, so reading and writing hold no JSON node per draw.
mod hex_bits {
    use serde::de::Error;
    use serde::{Deserialize, Deserializer, Serializer};
    use std::fmt::Write as _;

    pub fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let mut t = String::with_capacity(16 * v.len());
        for x in v {
            let _ = write!(t, "{:016x}", x.to_bits());
        }
        s.serialize_str(&t)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        let t = String::deserialize(d)?;
        if t.len() % 16 != 0 || !t.is_ascii() {
            return Err(D::Error::custom("not 16 hex digits a value"));
        }
        t.as_bytes()
            .chunks(16)
            .map(|c| {
                std::str::from_utf8(c)
                    .ok()
                    .and_then(|h| u64::from_str_radix(h, 16).ok())
                    .map(f64::from_bits)
                    .ok_or_else(|| D::Error::custom("not 16 hex digits a value"))
            })
            .collect()
    }
}

/// The grid indices of the reached cells and their fingerprint.
fn reached_hash(cells: impl Iterator<Item = usize>) -> String {
    let mut h = Fnv::new();
    cells.for_each(|c| h.write(&(c as u64).to_le_bytes()));
    h.hex()
}

impl MapShard {
    /// The `kind` of a map shard.
    pub const KIND: &'static str = "map shard";

    /// The shard `[k, n]` of the map `spec` that holds reached cells `[first, end)` of
    /// `solutions` ([`MapSpec::solve`]) with `errors` ([`super::evaluate_cells`] on those cells);
    /// `provenance` is that of the problem of all reached cells over all draws.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        provenance: Provenance,
        shard: [u64; 2],
        spec: &MapSpec,
        thresholds: &[f64],
        solutions: &[Option<CellIk>],
        (first, end): (usize, usize),
        errors: CellErrors,
        backend: BackendInfo,
        timings: Timings,
    ) -> MapShard {
        let reached = || {
            solutions
                .iter()
                .enumerate()
                .filter_map(|(i, s)| s.map(|ik| (i, ik)))
        };
        let cells = reached()
            .skip(first)
            .take(end - first)
            .zip(errors.cells)
            .map(|((cell, ik), stats)| ShardCell { cell, ik, stats })
            .collect();
        MapShard {
            kind: Self::KIND.to_string(),
            provenance,
            shard,
            base_origin_mm: [0.0; 3],
            spec: spec.clone(),
            thresholds: thresholds.to_vec(),
            reached_hash: reached_hash(reached().map(|(i, _)| i)),
            first,
            end,
            backend: [backend.backend, backend.adapter, backend.driver],
            timings,
            cells,
            w_bits: errors.w,
        }
    }

    /// The shard with the base frame's origin at `origin` (mm, the description's frame).
    pub fn with_base_origin(mut self, origin: [f64; 3]) -> MapShard {
        self.base_origin_mm = origin;
        self
    }

    /// The shard as JSON, with the bits of every float (`float_bits`).
    pub fn to_json(&self) -> String {
        // Plain data with finite floats: converting and serialising cannot fail.
        let mut v = serde_json::to_value(self).unwrap_or_default();
        let mut bits = Vec::new();
        visit_floats(&mut v, &mut |x| {
            bits.push(x.as_f64().unwrap_or(f64::NAN).to_bits());
        });
        if let Value::Object(o) = &mut v {
            o.insert("float_bits".into(), bits.into());
        }
        crate::mc::summary::checksum::seal(&serde_json::to_string(&v).unwrap_or_default())
    }

    /// Reads a shard written by [`MapShard::to_json`], its floats from their bits; `file` names
    /// it in errors.
    ///
    /// # Errors
    ///
    /// [`SummaryError::Corrupt`] when `text` is not a map shard: not JSON of its form, float bits
    /// that do not match the floats, or fields that are inconsistent with each other.
    pub fn from_json(text: &str, file: &str) -> Result<MapShard, SummaryError> {
        let corrupt = |message: String| SummaryError::Corrupt {
            file: file.to_string(),
            message,
        };
        let text = crate::mc::summary::checksum::verify(text, file)?;
        let mut v: Value = serde_json::from_str(&text).map_err(|e| corrupt(e.to_string()))?;
        let bits: Vec<u64> = match &mut v {
            Value::Object(o) => o.remove("float_bits"),
            _ => None,
        }
        .map(serde_json::from_value)
        .transpose()
        .map_err(|e| corrupt(format!("field `float_bits`: {e}")))?
        .ok_or_else(|| corrupt("missing field `float_bits`".into()))?;
        let mut exact = bits.iter().map(|&b| f64::from_bits(b));
        let (mut count, mut differs) = (0usize, false);
        visit_floats(&mut v, &mut |x| {
            count += 1;
            let read = x.as_f64().unwrap_or(f64::NAN);
            match exact.next().and_then(Number::from_f64) {
                Some(n) => {
                    let e = n.as_f64().unwrap_or(f64::NAN);
                    // A JSON number reads back within an ulp or so of the value written.
                    differs |= (read - e).abs() > 4.0 * f64::EPSILON * e.abs() + f64::MIN_POSITIVE;
                    *x = Value::Number(n);
                }
                None => differs = true,
            }
        });
        if differs || count != bits.len() {
            return Err(corrupt(format!(
                "field `float_bits` does not match the {count} numbers of the file"
            )));
        }
        let s: MapShard = serde_json::from_value(v).map_err(|e| corrupt(e.to_string()))?;
        let p = &s.provenance;
        let t = s.thresholds.len();
        let w_ok = s.w_bits.iter().all(|w| w.is_finite() && *w >= 0.0);
        let checks = [
            (s.kind == Self::KIND, "kind"),
            (s.shard[0] < s.shard[1], "shard"),
            (
                p.first == 0 && p.end == p.draws && p.draws > 0,
                "provenance draw range",
            ),
            (s.first < s.end && s.end <= p.points, "first/end"),
            (s.cells.len() == s.end - s.first, "cells"),
            (s.spec.n_cells() <= MAX_CELLS, "spec"),
            (
                s.cells.windows(2).all(|c| c[0].cell < c[1].cell)
                    && s.cells.last().is_none_or(|c| c.cell < s.spec.n_cells()),
                "cells",
            ),
            (
                t > 0
                    && s.cells.iter().all(|c| {
                        c.stats.reliability.len() == t
                            && c.stats
                                .reliability
                                .iter()
                                .zip(&s.thresholds)
                                .all(|(r, l)| r.threshold == *l)
                    }),
                "thresholds",
            ),
            (s.w_bits.len() as u64 == p.draws && w_ok, "w_bits"),
        ];
        if let Some((_, field)) = checks.iter().find(|(ok, _)| !ok) {
            return Err(corrupt(format!("field `{field}` is inconsistent")));
        }
        Ok(s)
    }
}

/// Calls `f` on every float of `v` (numbers written with a fraction or an exponent), depth first
/// in the order of the text (serde_json keeps an object's keys in one order on writing and
/// reading).
fn visit_floats(v: &mut Value, f: &mut impl FnMut(&mut Value)) {
    if matches!(v, Value::Number(n) if n.is_f64()) {
        f(v);
        return;
    }
    match v {
        Value::Array(a) => a.iter_mut().for_each(|x| visit_floats(x, f)),
        Value::Object(o) => o.values_mut().for_each(|x| visit_floats(x, f)),
        _ => {}
    }
}

/// The map of named shards that together hold every reached cell of one map once: they must
/// agree on provenance, grid, thresholds, the reached cells and the kind of backend, and their
/// ranges must tile the reached cells. The result does not depend on the order given and equals
/// one run's map apart from the timings (the longest shard's inverse kinematics, the sum of the
/// shards' evaluations) and, where the shards ran on different adapters, the backend ("mixed: …").
///
/// # Errors
///
/// [`SummaryError::Empty`] for no shards, [`SummaryError::Mismatch`] naming the first field on
/// which a shard differs from the first, and [`SummaryError::Range`] when the shards' ranges of
/// reached cells overlap or leave cells missing.
pub fn merge(named: &[(String, MapShard)]) -> Result<MapResult, SummaryError> {
    let order = in_range_order(
        named,
        "reached cells",
        |s| (s.first as u64, s.end as u64, s.provenance.points as u64),
        |s| {
            let mut v = provenance_fields(&s.provenance);
            v.extend([
                ("spec", serde_json::to_string(&s.spec).unwrap_or_default()),
                ("thresholds", format!("{:?}", s.thresholds)),
                ("reached_hash", s.reached_hash.clone()),
                ("backend", s.backend[0].clone()),
            ]);
            v
        },
    )?;
    let (first_file, first) = order[0];
    let (last_file, _) = order[order.len() - 1];
    let reached = order
        .iter()
        .flat_map(|(_, s)| s.cells.iter().map(|c| c.cell));
    if reached_hash(reached) != first.reached_hash {
        return Err(SummaryError::Corrupt {
            file: last_file.to_string(),
            message: format!("its cells and the others' are not the reached cells of {first_file}"),
        });
    }
    let mut solutions = vec![None; first.spec.n_cells()];
    let mut stats = Vec::with_capacity(first.provenance.points);
    let mut w = first.w_bits.clone();
    let mut timings = Timings::default();
    for (_, s) in &order {
        for c in &s.cells {
            solutions[c.cell] = Some(c.ik);
            stats.push(c.stats.clone());
        }
        for (a, b) in w.iter_mut().zip(&s.w_bits) {
            *a = a.max(*b);
        }
        timings.ik_seconds = timings.ik_seconds.max(s.timings.ik_seconds);
        timings.eval_seconds += s.timings.eval_seconds;
    }
    let [backend, adapter, driver] =
        crate::mc::summary::merged_backend(order.iter().map(|(_, s)| &s.backend));
    let p = &first.provenance;
    Ok(MapResult::new(
        &p.model,
        &first.spec,
        p.seed,
        solutions,
        Evaluation::new(stats, w, &first.thresholds),
        BackendInfo {
            backend,
            adapter,
            driver,
        },
        timings,
    )
    .with_base_origin(first.base_origin_mm))
}
