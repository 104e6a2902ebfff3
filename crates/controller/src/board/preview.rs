//! Planning a move without running it (the web page's preview). [`Board::group_move`]
//! plans through [`Board::plan_group`] too, so what is previewed is what would run.

use super::{Board, Profile};
use crate::domain::{Amount, MoveOpts};
use crate::error::CtlError;
use multistep_core::tdm::TdmConfig;

/// One axis of a previewed move.
#[derive(Clone, Debug)]
pub struct PlannedAxis {
    pub axis: String,
    /// Signed steps the move would make (periodic axes: the shortest way).
    pub delta: i64,
    /// Counted position at the end.
    pub target: i64,
    /// `None` when the axis would not move.
    pub profile: Option<Profile>,
}

/// Axis indices with signed step counts, their profiles (`None`: stays put), and the
/// clock they play on ([`Board::play_clock`]).
type GroupPlan = (Vec<(usize, i64)>, Vec<Option<Profile>>, f64);

impl Board {
    /// The planning half of [`Board::group_move`]: each named axis with its signed step
    /// count and profile (`None`: it stays put). Refuses what a run would refuse before
    /// timing: unknown or repeated axes, busy axes, e-stop, limits, plan errors.
    pub(super) fn plan_group(
        &self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
    ) -> Result<GroupPlan, CtlError> {
        let mut plan = Vec::new();
        for (name, amount) in targets {
            let i = self.index(name)?;
            if plan.iter().any(|&(j, _)| j == i) {
                return Err(CtlError::syntax(format!("axis {name} is named twice")));
            }
            self.check_can_move(i)?;
            plan.push((i, self.delta(i, *amount, absolute)?));
        }
        // The TDM engine times every edge of the group before it starts: bound that work.
        let total: u128 = plan
            .iter()
            .map(|&(i, d)| self.axes[i].motor_steps(d) as u128)
            .sum();
        if total > super::MAX_TIMED_STEPS as u128 {
            return Err(CtlError::Timing(format!(
                "the move is {total} steps in all, more than the {} one move or group may have; split it",
                super::MAX_TIMED_STEPS
            )));
        }
        // a sync group's phase times are stretched to the board's seconds
        let clock = if sync {
            self.clock_hz
        } else {
            self.play_clock(&self.resolve_opts(opts)?)
        };
        let profiles = if sync {
            self.plan_sync(&plan, opts)?
        } else {
            plan.iter()
                .map(|&(i, d)| {
                    if d == 0 {
                        Ok(None)
                    } else {
                        self.plan(i, self.axes[i].motor_steps(d), opts).map(Some)
                    }
                })
                .collect::<Result<Vec<_>, _>>()?
        };
        Ok((plan, profiles, clock))
    }

    /// What `group_move(targets, absolute, sync, opts)` would run from the counted
    /// positions now, without starting anything.
    pub fn preview(
        &self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
    ) -> Result<Vec<PlannedAxis>, CtlError> {
        self.plan_preview(targets, absolute, sync, opts)?.time()
    }

    /// The planning half of [`Board::preview`]; its TDM timing ([`PreviewPlan::time`])
    /// needs no board, so a service runs it with the board free.
    pub fn plan_preview(
        &self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
    ) -> Result<PreviewPlan, CtlError> {
        let (plan, profiles, clock_hz) = self.plan_group(targets, absolute, sync, opts)?;
        let axes = plan
            .iter()
            .zip(profiles)
            .map(|(&(i, delta), profile)| {
                let ax = &self.axes[i];
                let t = ax.count + delta;
                PlannedAxis {
                    axis: ax.name.clone(),
                    delta,
                    target: ax.period().map_or(t, |p| t.rem_euclid(p)),
                    profile,
                }
            })
            .collect();
        Ok(PreviewPlan {
            axes,
            tdm: TdmConfig {
                clock_hz,
                ..self.tdm
            },
        })
    }
}

/// A previewed group, planned but not yet checked against the TDM calculator.
pub struct PreviewPlan {
    axes: Vec<PlannedAxis>,
    tdm: TdmConfig,
}

impl PreviewPlan {
    /// The same timing check as a run: a group the TDM calculator cannot keep up with is
    /// refused here too. Takes as long as timing the move (up to seconds).
    pub fn time(self) -> Result<Vec<PlannedAxis>, CtlError> {
        let moving: Vec<Profile> = self.axes.iter().filter_map(|a| a.profile.clone()).collect();
        if !moving.is_empty() {
            crate::motion::start_group(&moving, &self.tdm, 0)?;
        }
        Ok(self.axes)
    }
}
