//! The `multistep tdm` config file (TOML): the board, then one `[[axis]]` table per axis
//! whose keys are the plan flags in snake_case. Every axis resolves through
//! `multistep_core::MoveSpec`, the one reading of move values.

use anyhow::{bail, Context};
use multistep_core::tdm::{Latencies, Policy, PulseShape, TdmConfig};
use multistep_core::{
    MoveParams, MoveSpec, Num, Param, Profile, Segment, StepDirTiming, DEFAULT_CLOCK_HZ, PARAMS,
};
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use std::fmt;
use std::path::Path;

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct ConfigFile {
    /// Clock (Hz) of calculator, pulse units and edge ticks (default 50 MHz), > 0 and at
    /// least every axis's peak speed (steps/s).
    pub clock: Option<f64>,
    /// Periods each axis's FIFO holds, 1 to 128 (default 1).
    pub fifo_depth: Option<usize>,
    /// round-robin (default) or earliest-deadline; `--policy` overrides it.
    pub policy: Option<String>,
    /// Calculator latencies in cycles, 0 to 2³² − 1 each, not all 0 (defaults: the radix-4
    /// datapath of the Verilog core, 51 cycles/period).
    pub mul_cycles: Option<u32>,
    pub div_cycles: Option<u32>,
    pub sqrt_cycles: Option<u32>,
    pub overhead_cycles: Option<u32>,
    /// Overlap periods of different axes across the units (default false).
    pub pipelined: Option<bool>,
    /// Least ticks from DIR set (tick 0) to the group's start (default 0), at most one
    /// second of the clock.
    pub dir_setup_ticks: Option<u64>,
    /// Fixed STEP high time in ticks, 1 to one second of the clock; absent: half of the
    /// interval to the next edge.
    pub pulse_width_ticks: Option<u64>,
    #[serde(default)]
    pub axis: Vec<AxisEntry>,
}

/// One axis: a move by the plan's flag names, in snake_case. Read key by key (below):
/// the move values are the core's list, so a value the core adds is a key here too.
#[derive(Debug, Default, Clone)]
pub struct AxisEntry {
    /// Optional label for reports.
    pub name: Option<String>,
    pub profile: Option<String>,
    pub steps: Option<u64>,
    /// Times, speeds, limits and shape fractions by their flag names.
    pub params: MoveParams,
    /// `[[v0, t, n], ...]`: steps/s, s, steps.
    pub segments: Option<Vec<(f64, f64, u64)>>,
}

/// Every key of an `[[axis]]` table, for the message that names a wrong one.
static AXIS_KEYS: [&str; PARAMS.len() + 4] = {
    let mut keys = [""; PARAMS.len() + 4];
    (keys[0], keys[1], keys[2]) = ("name", "profile", "steps");
    let mut i = 0;
    while i < PARAMS.len() {
        keys[3 + i] = PARAMS[i].name;
        i += 1;
    }
    keys[PARAMS.len() + 3] = "segments";
    keys
};

enum AxisKey {
    Name,
    Profile,
    Steps,
    Segments,
    Param(&'static Param),
}

impl<'de> Deserialize<'de> for AxisKey {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct KeyVisitor;
        impl Visitor<'_> for KeyVisitor {
            type Value = AxisKey;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an axis key")
            }
            fn visit_str<E: de::Error>(self, key: &str) -> Result<AxisKey, E> {
                Ok(match key {
                    "name" => AxisKey::Name,
                    "profile" => AxisKey::Profile,
                    "steps" => AxisKey::Steps,
                    "segments" => AxisKey::Segments,
                    _ => AxisKey::Param(
                        Param::named(key).ok_or_else(|| E::unknown_field(key, &AXIS_KEYS))?,
                    ),
                })
            }
        }
        d.deserialize_identifier(KeyVisitor)
    }
}

impl<'de> Deserialize<'de> for AxisEntry {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct EntryVisitor;
        impl<'de> Visitor<'de> for EntryVisitor {
            type Value = AxisEntry;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an [[axis]] table")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<AxisEntry, A::Error> {
                let mut a = AxisEntry::default();
                while let Some(key) = map.next_key()? {
                    match key {
                        AxisKey::Name => a.name = Some(map.next_value()?),
                        AxisKey::Profile => a.profile = Some(map.next_value()?),
                        AxisKey::Steps => a.steps = Some(map.next_value()?),
                        AxisKey::Segments => a.segments = Some(map.next_value()?),
                        AxisKey::Param(p) => *(p.slot)(&mut a.params) = Some(map.next_value()?),
                    }
                }
                Ok(a)
            }
        }
        d.deserialize_struct("AxisEntry", &AXIS_KEYS, EntryVisitor)
    }
}

impl AxisEntry {
    /// The axis's move as it plays on a clock of `clock_hz` (limits-mode trapezoids on
    /// whole ticks, as `plan` and the integer datapath).
    pub fn plan(&self, clock_hz: f64) -> Result<Profile, multistep_core::PlanError> {
        let segments: Vec<Segment> = self
            .segments
            .iter()
            .flatten()
            .map(|&(v0, duration, steps)| Segment {
                v0,
                duration,
                steps,
            })
            .collect();
        MoveSpec {
            profile: self.profile.as_deref(),
            steps: self.steps,
            params: self.params,
            segments: &segments,
        }
        .plan_on_clock(clock_hz)
    }
}

impl ConfigFile {
    pub fn load(path: &Path) -> anyhow::Result<ConfigFile> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        Self::parse(&text).with_context(|| format!("in {}", path.display()))
    }

    pub fn parse(text: &str) -> anyhow::Result<ConfigFile> {
        Ok(toml::from_str(text)?)
    }

    /// The board settings; `policy` (from the command line) wins over the file's.
    pub fn board(&self, policy: Option<Policy>) -> anyhow::Result<TdmConfig> {
        let d = Latencies::default();
        let clock_hz = self.clock.unwrap_or(DEFAULT_CLOCK_HZ);
        if !(clock_hz.is_finite() && clock_hz > 0.0) {
            bail!(
                "clock = {} must be a finite number of Hz > 0",
                Num(clock_hz)
            );
        }
        // STEP pulses and DIR setup times are microseconds: a second of them is a mistake
        let second = (clock_hz as u64).max(1);
        for (key, ticks) in [
            ("pulse_width_ticks", self.pulse_width_ticks),
            ("dir_setup_ticks", self.dir_setup_ticks),
        ] {
            if let Some(t) = ticks.filter(|&t| t > second) {
                bail!(
                    "{key} = {t} is more than one second of the {} Hz clock: it must be at \
                     most {second} ticks",
                    Num(clock_hz)
                );
            }
        }
        let policy = match (policy, &self.policy) {
            (Some(p), _) => p,
            (None, Some(name)) => {
                Policy::parse(name).with_context(|| format!("policy '{name}'"))?
            }
            (None, None) => Policy::RoundRobin,
        };
        Ok(TdmConfig {
            clock_hz,
            fifo_depth: self.fifo_depth.unwrap_or(1),
            latencies: Latencies {
                mul: self.mul_cycles.unwrap_or(d.mul),
                div: self.div_cycles.unwrap_or(d.div),
                sqrt: self.sqrt_cycles.unwrap_or(d.sqrt),
                overhead: self.overhead_cycles.unwrap_or(d.overhead),
                pipelined: self.pipelined.unwrap_or(d.pipelined),
            },
            policy,
            step_dir: StepDirTiming {
                pulse: match self.pulse_width_ticks {
                    Some(ticks) => PulseShape::Fixed { ticks },
                    None => PulseShape::HalfInterval,
                },
                dir_setup_ticks: self.dir_setup_ticks.unwrap_or(0),
            },
        })
    }

    /// Each axis's label: its `name`, or its index.
    pub fn axis_names(&self) -> Vec<String> {
        self.axis
            .iter()
            .enumerate()
            .map(|(k, a)| a.name.clone().unwrap_or_else(|| k.to_string()))
            .collect()
    }

    /// Every axis's profile, errors named by axis.
    pub fn profiles(&self) -> anyhow::Result<Vec<Profile>> {
        if self.axis.is_empty() {
            bail!("the config has no [[axis]] table");
        }
        self.axis
            .iter()
            .enumerate()
            .map(|(i, a)| {
                a.plan(self.clock.unwrap_or(DEFAULT_CLOCK_HZ))
                    .with_context(|| format!("axis {i}{}", label(&a.name)))
            })
            .collect()
    }
}

fn label(name: &Option<String>) -> String {
    name.as_ref().map(|n| format!(" ({n})")).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_board_and_every_move_mode() {
        let cfg = ConfigFile::parse(
            r#"
            clock = 50e6
            fifo_depth = 2
            div_cycles = 40
            pipelined = true
            pulse_width_ticks = 100
            [[axis]]
            steps = 2400
            accel_time = 0.02
            cruise_time = 0.01
            decel_time = 0.02
            [[axis]]
            profile = "scurve"
            steps = 1000
            vmax = 5000
            amax = 50000
            jmax = 1e6
            [[axis]]
            segments = [[0, 0.02, 40], [4000, 0.01, 40], [4000, 0.02, 40]]
            "#,
        )
        .unwrap();
        let b = cfg.board(None).unwrap();
        assert_eq!(b.fifo_depth, 2);
        assert_eq!(b.latencies.div, 40);
        assert_eq!(b.latencies.sqrt, Latencies::default().sqrt);
        assert!(b.latencies.pipelined);
        assert_eq!(b.step_dir.pulse, PulseShape::Fixed { ticks: 100 });
        assert_eq!(b.policy, Policy::RoundRobin);
        let p = cfg.profiles().unwrap();
        assert_eq!(
            p.iter().map(|p| p.steps()).collect::<Vec<_>>(),
            [2400, 1000, 120]
        );
        assert_eq!(
            cfg.board(Some(Policy::EarliestDeadline)).unwrap().policy,
            Policy::EarliestDeadline
        );
    }

    #[test]
    fn unknown_keys_and_bad_moves_are_errors() {
        assert!(ConfigFile::parse("fifo_dept = 2").is_err());
        let e = ConfigFile::parse("[[axis]]\nstep = 3")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2") && e.contains("unknown field `step`"),
            "{e}"
        );
        assert!(e.contains("`steps`") && e.contains("`accel_time`"), "{e}");
        let cfg = ConfigFile::parse("[[axis]]\nname = \"x\"\nsteps = 3").unwrap();
        let e = format!("{:#}", cfg.profiles().unwrap_err());
        assert!(e.contains("axis 0 (x)") && e.contains("phase times"), "{e}");
        let cfg =
            ConfigFile::parse("policy = \"lottery\"\n[[axis]]\nsteps = 3\naccel_time = 1").unwrap();
        assert!(cfg.board(None).is_err());
    }
}
