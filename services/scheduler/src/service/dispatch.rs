//! Fair dispatch: the scheduler publishes a campaign's tile tasks a few at a time, so one agency's backlog
//! cannot stand in front of another agency's work.
//!
//! The work queue is one FIFO stream for everyone. Publishing every task at submission would put a 200-tile
//! campaign's tasks ahead of anything submitted after it. Instead every agency may have at most
//! [`Quotas::dispatch_window`](super::Quotas) tasks *out* — published and not yet handled (done or failed)
//! by the adjuster's count — and the rest waits in the campaign's state (`dispatched` of `tiles_total`,
//! in plan order). A round tops every agency up to its window; agencies take turns one task at a time, and so
//! do an agency's campaigns (oldest first), so a task of agency B waits behind at most a window of A's.
//!
//! Rounds run after every submission and every [`ROUND_INTERVAL`] (tiles finish without the scheduler being
//! told). A task is published before `dispatched` is raised, so a crash in between publishes it again with
//! the same `Nats-Msg-Id`, which the stream drops. Where the plan and the tasks' locations come from is
//! derived from agency and id (the agency's stored manifest), never from the state.

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::Duration;

use plumbline_campaign::CampaignId;
use plumbline_campaign::plan::PlanDoc;
use plumbline_geo::tiling::TileId;

use super::Scheduler;
use super::prefix::{StoredOutputError, stored_output};
use crate::bus::BusError;
use crate::messages::{Agency, CampaignState, TileTask};

/// Time between dispatch rounds when nothing wakes the dispatcher.
pub const ROUND_INTERVAL: Duration = Duration::from_secs(1);

/// A campaign with tasks still to publish, for [`order`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pending {
    /// Its agency.
    pub agency: Agency,
    /// Tasks not yet published.
    pub remaining: u64,
}

/// The order of the next tasks to publish: one index into `pending` per task. Agency `a` may publish
/// `window − out[a]` more (`out`: tasks published and not yet handled); agencies take turns one task at a
/// time (in name order), and within an agency its campaigns take turns (in the order given).
pub fn order(pending: &[Pending], out: &HashMap<Agency, u64>, window: u64) -> Vec<usize> {
    let mut agencies: BTreeMap<&Agency, (u64, Vec<usize>, usize)> = BTreeMap::new();
    for (i, p) in pending.iter().enumerate() {
        let entry = agencies
            .entry(&p.agency)
            .or_insert_with(|| (window.saturating_sub(out.get(&p.agency).copied().unwrap_or(0)), Vec::new(), 0));
        entry.1.push(i);
    }
    let mut remaining: Vec<u64> = pending.iter().map(|p| p.remaining).collect();
    let mut out_order = Vec::new();
    loop {
        let mut progressed = false;
        for (budget, campaigns, turn) in agencies.values_mut() {
            if *budget == 0 {
                continue;
            }
            // The agency's next campaign (in turn) with tasks left.
            let found =
                (0..campaigns.len()).map(|k| (*turn + k) % campaigns.len()).find(|&k| remaining[campaigns[k]] > 0);
            let Some(k) = found else { continue };
            let i = campaigns[k];
            out_order.push(i);
            remaining[i] -= 1;
            *budget -= 1;
            *turn = (k + 1) % campaigns.len();
            progressed = true;
        }
        if !progressed {
            return out_order;
        }
    }
}

/// The plans' tiles by campaign run, read once.
pub(super) type PlanCache = HashMap<(Agency, CampaignId, u32), Arc<Vec<TileId>>>;

/// Why a campaign's target was not had: `permanent` (with the reason) when it never will be.
struct TargetError {
    permanent: Option<String>,
    message: String,
}

/// Where the tasks of a campaign point and its tiles in plan order.
struct Target {
    manifest: String,
    output: String,
    tiles: Arc<Vec<TileId>>,
}

impl Target {
    /// The task of `tile` of the campaign in `state`'s run.
    fn task(&self, state: &CampaignState, tile: TileId) -> TileTask {
        TileTask {
            agency: state.agency.clone(),
            campaign: state.id.clone(),
            run: state.run,
            manifest: self.manifest.clone(),
            tile,
            output: self.output.clone(),
        }
    }
}

impl Scheduler {
    /// Remember a planned campaign's tiles (at submission, so its first round needs no read).
    pub(super) fn remember_plan(&self, state: &CampaignState, tiles: Vec<TileId>) {
        if let Ok(mut plans) = self.plans.lock() {
            plans.insert((state.agency.clone(), state.id.clone(), state.run), Arc::new(tiles));
        }
    }

    /// One dispatch round (rounds never overlap); the tasks published.
    pub async fn dispatch(&self) -> Result<u64, BusError> {
        let _one_at_a_time = self.dispatching.lock().await;
        let states = self.bus.campaigns.list().await?;
        let active: Vec<&CampaignState> = states.iter().filter(|c| !c.status.is_terminal()).collect();
        if let Ok(mut plans) = self.plans.lock() {
            plans.retain(|(agency, id, run), _| {
                active.iter().any(|c| c.agency == *agency && c.id == *id && c.run == *run)
            });
        }
        let mut out: HashMap<Agency, u64> = HashMap::new();
        for c in &active {
            *out.entry(c.agency.clone()).or_default() += c.dispatched.saturating_sub(c.tiles_handled());
        }
        let mut waiting: Vec<&CampaignState> = active.into_iter().filter(|c| c.dispatched < c.tiles_total).collect();
        waiting.sort_by(|a, b| (a.created, &a.agency, &a.id).cmp(&(b.created, &b.agency, &b.id)));
        let pending: Vec<Pending> = waiting
            .iter()
            .map(|c| Pending { agency: c.agency.clone(), remaining: c.tiles_total - c.dispatched })
            .collect();
        let order = order(&pending, &out, self.quotas.dispatch_window);
        if order.is_empty() {
            return Ok(0);
        }
        let mut targets: HashMap<usize, Option<Target>> = HashMap::new();
        let mut next: Vec<u64> = waiting.iter().map(|c| c.dispatched).collect();
        let (mut stored, mut duplicates) = (0, 0);
        let mut failure = None;
        for i in order {
            let state = waiting[i];
            if let std::collections::hash_map::Entry::Vacant(slot) = targets.entry(i) {
                slot.insert(self.target_or_fail(state).await);
            }
            let Some(Some(target)) = targets.get(&i) else { continue };
            let Some(tile) = usize::try_from(next[i]).ok().and_then(|k| target.tiles.get(k)) else { continue };
            match self.bus.publish_task(&target.task(state, *tile)).await {
                Ok(true) => stored += 1,
                Ok(false) => duplicates += 1,
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            }
            next[i] += 1;
        }
        self.metrics.tasks(stored, duplicates);
        for (i, state) in waiting.iter().enumerate() {
            if next[i] == state.dispatched {
                continue;
            }
            let (run, upto) = (state.run, next[i]);
            self.bus
                .campaigns
                .modify(&state.agency, &state.id, |c| {
                    let raise = c.run == run && c.dispatched < upto;
                    if raise {
                        c.dispatched = upto;
                    }
                    raise
                })
                .await?;
        }
        if stored > 0 {
            tracing::info!(stored, duplicates, "tasks dispatched");
        }
        match failure {
            Some(e) => Err(e),
            None => Ok(stored),
        }
    }

    /// Publish the tasks of a campaign's dispatched tiles again (de-duplicated by the stream within its
    /// window; what a lost stream or a failed submission left out comes back).
    pub(super) async fn republish(&self, state: &CampaignState) -> Result<(), String> {
        let target = self.target(state).await.map_err(|e| e.message)?;
        let dispatched = usize::try_from(state.dispatched).unwrap_or(usize::MAX);
        let (mut stored, mut duplicates) = (0, 0);
        for tile in target.tiles.iter().take(dispatched) {
            match self.bus.publish_task(&target.task(state, *tile)).await {
                Ok(true) => stored += 1,
                Ok(false) => duplicates += 1,
                Err(e) => {
                    self.metrics.tasks(stored, duplicates);
                    return Err(e.to_string());
                }
            }
        }
        self.metrics.tasks(stored, duplicates);
        Ok(())
    }

    /// [`Self::target`]; a campaign whose target can never be had (its state or stored manifest tampered
    /// with, its plan unreadable) is set `failed` with the reason, a store failure is logged and tried again
    /// next round.
    async fn target_or_fail(&self, state: &CampaignState) -> Option<Target> {
        let e = match self.target(state).await {
            Ok(target) => return Some(target),
            Err(e) => e,
        };
        let (agency, id) = (state.agency.as_str(), state.id.as_str());
        let Some(reason) = e.permanent else {
            tracing::warn!(campaign = id, agency, error = e.message, "campaign not dispatched this round");
            return None;
        };
        tracing::error!(campaign = id, agency, error = reason, "campaign cannot be dispatched; failed");
        let run = state.run;
        let failed = self.bus.campaigns.modify(&state.agency, &state.id, |c| {
            let fail = c.run == run && !c.status.is_terminal();
            if fail {
                c.status = crate::messages::CampaignStatus::Failed;
                c.error = Some(format!("dispatch: {reason}"));
            }
            fail
        });
        if let Err(e) = failed.await {
            tracing::warn!(campaign = id, agency, error = %e, "could not mark the campaign failed");
        }
        None
    }

    /// The stored manifest, output prefix and planned tiles of a campaign, derived from its agency and id.
    async fn target(&self, state: &CampaignState) -> Result<Target, TargetError> {
        let (manifest, output) = stored_output(&self.files, &self.layout, &state.agency, state).await.map_err(|e| {
            let permanent = matches!(e, StoredOutputError::Tampered(_)).then(|| e.to_string());
            TargetError { permanent, message: e.to_string() }
        })?;
        let key = (state.agency.clone(), state.id.clone(), state.run);
        let cached = self.plans.lock().ok().and_then(|plans| plans.get(&key).cloned());
        let tiles = match cached {
            Some(tiles) => tiles,
            None => {
                let url = format!("{output}plan.json");
                let bytes = self
                    .files
                    .read(&url)
                    .await
                    .map_err(|e| TargetError { permanent: None, message: format!("{url}: {e:#}") })?;
                let PlanDoc::V1(plan) = serde_json::from_slice(&bytes).map_err(|e| {
                    let message = format!("{url}: {e}");
                    TargetError { permanent: Some(message.clone()), message }
                })?;
                let tiles: Arc<Vec<TileId>> = Arc::new(plan.tiles.tiles().iter().map(|t| t.id).collect());
                if let Ok(mut plans) = self.plans.lock() {
                    plans.insert(key, tiles.clone());
                }
                tiles
            }
        };
        Ok(Target { manifest, output, tiles })
    }
}

/// Run dispatch rounds every [`ROUND_INTERVAL`] and whenever woken, until the scheduler is dropped.
pub(super) fn spawn_dispatcher(scheduler: &Arc<Scheduler>) {
    let weak = Arc::downgrade(scheduler);
    let wake = scheduler.wake.clone();
    tokio::spawn(async move {
        loop {
            tokio::select! {
                () = tokio::time::sleep(ROUND_INTERVAL) => {}
                () = wake.notified() => {}
            }
            let Some(scheduler) = weak.upgrade() else { return };
            if let Err(e) = scheduler.dispatch().await {
                tracing::warn!(error = %e, "dispatch round failed; retrying");
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn agency(name: &str) -> Agency {
        Agency::parse(name).unwrap()
    }

    fn pending(list: &[(&str, u64)]) -> Vec<Pending> {
        list.iter().map(|(a, n)| Pending { agency: agency(a), remaining: *n }).collect()
    }

    #[test]
    fn a_backlog_does_not_stand_before_another_agencys_tile() {
        // Agency a: 200 tiles waiting, 4 out already; agency b: one tile.
        let p = pending(&[("a", 200), ("b", 1)]);
        let out = HashMap::from([(agency("a"), 4)]);
        let order = order(&p, &out, 8);
        assert_eq!(order, [0, 1, 0, 0, 0], "a may add 4 to its 4 out, b's one tile goes second");
        // a's window full: only b's tile is published.
        assert_eq!(super::order(&p, &HashMap::from([(agency("a"), 8)]), 8), [1]);
    }

    #[test]
    fn an_agencys_campaigns_take_turns_and_nothing_passes_the_window() {
        let p = pending(&[("a", 5), ("a", 2), ("b", 3)]);
        let order = order(&p, &HashMap::new(), 4);
        assert_eq!(order, [0, 2, 1, 2, 0, 2, 1]);
        assert_eq!(super::order(&p, &HashMap::new(), 0), Vec::<usize>::new());
        assert_eq!(super::order(&p, &HashMap::new(), 100).len(), 10, "everything when the window allows");
    }
}
