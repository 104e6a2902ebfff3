//! Planning a move without running it (the web page's preview): the same option
//! resolution, limits and planner as [`Board::group_move`], so what is previewed is what
//! would run.

use super::{Board, Profile};
use crate::error::CtlError;
use crate::protocol::{Amount, MoveOpts};

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

impl Board {
    /// What `group_move(targets, absolute, sync, opts)` would plan from the counted
    /// positions now, without starting anything; busy axes are planned from where they
    /// are, so only the errors of the plan itself show.
    pub fn preview(
        &self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
    ) -> Result<Vec<PlannedAxis>, CtlError> {
        let mut plan = Vec::new();
        for (name, amount) in targets {
            let i = self.index(name)?;
            if plan.iter().any(|&(j, _)| j == i) {
                return Err(CtlError::syntax(format!("axis {name} is named twice")));
            }
            plan.push((i, self.delta(i, *amount, absolute)?));
        }
        let profiles = if sync {
            self.plan_sync(&plan, opts)?
        } else {
            plan.iter()
                .map(|&(i, d)| {
                    if d == 0 {
                        Ok(None)
                    } else {
                        self.plan(i, d.unsigned_abs(), opts).map(Some)
                    }
                })
                .collect::<Result<Vec<_>, _>>()?
        };
        Ok(plan
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
            .collect())
    }
}
