//! Writing the results of `plumbline adjust`: the corrected trajectory in the input's format, the per-epoch
//! corrections with posterior σ, and the JSON summary.

use plumbline_adjustment::{Adjustment, WeakLink};
use plumbline_geo::Trajectory;
use serde_json::{Value, json};

use super::input::{LoadedTrajectory, Observations};
use crate::io::Context;

/// Write the corrected trajectory as the input came (format and CRS); returns the files written.
pub async fn trajectory(
    ctx: &Context,
    prefix: &str,
    input: &LoadedTrajectory,
    corrected: &Trajectory,
) -> anyhow::Result<Vec<String>> {
    Ok(plumbline_runtime::trajectory::write_like_input(ctx.files(), prefix, "trajectory", input, corrected).await?)
}

/// The summary: solver figures, rejected observations with their w-test values, skipped observations,
/// flagged epochs (weak-link intervals and the epochs of rejected observations) and the correction's size.
pub fn summary(
    result: &Adjustment,
    obs: &Observations,
    links: &[WeakLink],
    input: &LoadedTrajectory,
    written: &[String],
) -> Value {
    let rejected: Vec<Value> = result
        .rejected
        .iter()
        .map(|r| json!({"observation": obs.describe(&r.item), "item": r.item, "w": r.w, "round": r.round, "time": obs.time(&r.item)}))
        .collect();
    let skipped: Vec<Value> = result
        .skipped
        .iter()
        .map(|s| json!({"observation": obs.describe(&s.item), "item": s.item, "field": s.field, "problem": s.problem}))
        .collect();
    let mut flagged: Vec<Value> = links
        .iter()
        .map(|l| json!({"start": l.start, "end": l.end, "reason": "weak_link", "factor": l.factor}))
        .collect();
    flagged.extend(result.rejected.iter().filter_map(|r| {
        let t = obs.time(&r.item)?;
        Some(json!({"start": t, "end": t, "reason": "rejected_observation", "observation": obs.describe(&r.item)}))
    }));
    let files: Vec<Value> = obs.files.iter().map(|f| json!({"name": f.name})).collect();
    json!({
        "version": "1",
        "trajectory": input.name,
        "records": input.trajectory.len(),
        "observation_files": files,
        "observations": {"ties": obs.set.ties.len(), "poles": obs.set.poles.len(), "gnss": obs.set.gnss.len()},
        "nodes": result.nodes.len(),
        "iterations": result.iterations,
        "sigma0": result.sigma0,
        "redundancy": result.redundancy,
        "variance_factors": finite_or_null(&result.variance_factors),
        "rejected": rejected,
        "skipped": skipped,
        "flagged_epochs": flagged,
        "correction": correction_size(result),
        "outputs": written,
    })
}

/// Variance factors with NaN (no controlled rows) as null.
fn finite_or_null(v: &plumbline_adjustment::VarianceFactors) -> Value {
    let f = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    json!({"poles": f(v.poles), "gnss": f(v.gnss), "rays": f(v.rays), "aerial": f(v.aerial)})
}

/// Largest horizontal and vertical node correction, metres.
fn correction_size(result: &Adjustment) -> Value {
    let horizontal = result.nodes.iter().map(|n| n.position[0].hypot(n.position[1])).fold(0.0, f64::max);
    let vertical = result.nodes.iter().map(|n| n.position[2].abs()).fold(0.0, f64::max);
    json!({"max_horizontal_m": horizontal, "max_vertical_m": vertical})
}
