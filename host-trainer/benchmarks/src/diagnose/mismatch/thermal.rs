//! The mismatched set's chamber and gyro body: setpoint profiles (ramp cycles, day/night
//! sines, staircases), the chamber air's lag with the controller's hunting and overshoot,
//! and a two-node body (case and core) heated by the gyro itself after power-on.

use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::{log_uni, uni};

/// Lowest and highest chamber setpoint, °C.
const CHAMBER_MIN_C: f64 = -40.0;
const CHAMBER_MAX_C: f64 = 70.0;

/// Shortest hold of a ramp cycle, s.
const MIN_HOLD_S: f64 = 1800.0;

/// The setpoint programme.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Profile {
    /// Holds and ramps between the range's ends.
    Ramp {
        /// °C/min.
        rate_c_per_min: f64,
        /// Up-and-down cycles.
        cycles: usize,
        /// Each hold, s.
        hold_s: f64,
        /// Starts at the top of the range instead of the bottom.
        from_top: bool,
    },
    /// A day/night swing over the range.
    Sine {
        /// s.
        period_s: f64,
        /// rad.
        phase_rad: f64,
    },
    /// 15 °C steps up and down the range, each held for a soak.
    Staircase {
        /// s.
        soak_s: f64,
        /// Levels from the bottom of the range, 15 °C apart (the top one closer).
        levels: usize,
    },
}

/// Chamber control imperfections: the air hunts around the setpoint and overshoots at the
/// end of every ramp or step.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Hunting {
    /// Amplitude of the air's sine hunting, °C.
    pub amplitude_c: f64,
    /// Its period, s.
    pub period_s: f64,
    /// Its phase, rad.
    pub phase_rad: f64,
    /// Peak of the overshoot after a ramp or step, °C (in the direction of the change).
    pub overshoot_c: f64,
    /// Time from the end of the change to the overshoot's peak, s.
    pub overshoot_tau_s: f64,
}

/// The chamber: profile, range, record length and the air's control.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Chamber {
    /// Setpoint programme.
    pub profile: Profile,
    /// Bottom of the range, °C.
    pub lo_c: f64,
    /// Top of the range, °C.
    pub hi_c: f64,
    /// Record length, s.
    pub duration_s: f64,
    /// First-order lag of the air behind the setpoint, s.
    pub air_tau_s: f64,
    /// Hunting and overshoot, when the controller is badly tuned.
    pub hunting: Option<Hunting>,
    /// Setpoint knots (t s, °C), linear in between; equal times make a step.
    #[serde(skip)]
    knots: Vec<(f64, f64)>,
    /// Ends of ramps and steps: (t s, direction ±1).
    #[serde(skip)]
    events: Vec<(f64, f64)>,
}

impl Chamber {
    /// Draws a chamber programme (see the module doc of `mismatch`).
    pub(super) fn draw(rng: &mut ChaCha8Rng) -> Chamber {
        let lo = uni(rng, CHAMBER_MIN_C, 20.0);
        let mut hi = uni(rng, lo + 25.0, CHAMBER_MAX_C);
        let kind = (uni(rng, 0.0, 3.0) as usize).min(2);
        let mut knots = Vec::new();
        let mut events = Vec::new();
        let (profile, duration_s) = match kind {
            0 => {
                let rate = [0.3, 1.0, 3.0][(uni(rng, 0.0, 3.0) as usize).min(2)];
                let mut cycles = if uni(rng, 0.0, 1.0) < 0.5 { 2 } else { 3 };
                let len = (uni(rng, 10.0, 36.0) * 3600.0).round();
                let from_top = uni(rng, 0.0, 1.0) < 0.5;
                // Holds fill the record; fewer cycles, then a narrower range, when the ramps
                // alone would not leave half an hour per hold.
                let ramp_s = |range: f64| range / rate * 60.0;
                let hold = |c: usize, range: f64| {
                    (len - 2.0 * c as f64 * ramp_s(range)) / (2 * c + 1) as f64
                };
                if hold(cycles, hi - lo) < MIN_HOLD_S {
                    cycles = 2;
                }
                if hold(cycles, hi - lo) < MIN_HOLD_S {
                    let c = cycles as f64;
                    hi = lo + rate / 60.0 * (len - (2.0 * c + 1.0) * MIN_HOLD_S) / (2.0 * c);
                }
                let hold_s = hold(cycles, hi - lo).floor();
                let ramp = ramp_s(hi - lo);
                let (a, b) = if from_top { (hi, lo) } else { (lo, hi) };
                let dir = if from_top { -1.0 } else { 1.0 };
                let mut t = 0.0;
                knots.push((t, a));
                for _ in 0..cycles {
                    t += hold_s;
                    knots.push((t, a));
                    t += ramp;
                    knots.push((t, b));
                    events.push((t, dir));
                    t += hold_s;
                    knots.push((t, b));
                    t += ramp;
                    knots.push((t, a));
                    events.push((t, -dir));
                }
                let profile = Profile::Ramp {
                    rate_c_per_min: rate,
                    cycles,
                    hold_s,
                    from_top,
                };
                (profile, len)
            }
            1 => {
                let period_s = (uni(rng, 6.0, 24.0) * 3600.0).round();
                let phase_rad = uni(rng, 0.0, std::f64::consts::TAU);
                let len = (uni(rng, 24.0, 36.0) * 3600.0).round();
                (
                    Profile::Sine {
                        period_s,
                        phase_rad,
                    },
                    len,
                )
            }
            _ => {
                let soak_s = (uni(rng, 1.5, 3.0) * 3600.0).round();
                let len = (uni(rng, 10.0, 36.0) * 3600.0).round();
                // 15 °C steps from the bottom; a last, shorter step reaches the top.
                let mut level: Vec<f64> = (0..)
                    .map(|k| lo + 15.0 * f64::from(k))
                    .take_while(|v| *v < hi - 0.5)
                    .collect();
                level.push(hi);
                let levels = level.len();
                // Up the staircase and down again until the record ends.
                let (mut k, mut dir) = (0usize, 1i64);
                let mut t = 0.0;
                knots.push((t, lo));
                while t < len {
                    t += soak_s;
                    knots.push((t, level[k]));
                    if k + 1 == levels {
                        dir = -1;
                    } else if k == 0 {
                        dir = 1;
                    }
                    k = (k as i64 + dir) as usize;
                    knots.push((t, level[k]));
                    events.push((t, dir as f64));
                }
                (Profile::Staircase { soak_s, levels }, len)
            }
        };
        let air_tau_s = uni(rng, 120.0, 600.0);
        let hunting = (uni(rng, 0.0, 1.0) < 0.3).then(|| Hunting {
            amplitude_c: uni(rng, 0.05, 0.3),
            period_s: uni(rng, 8.0, 20.0) * 60.0,
            phase_rad: uni(rng, 0.0, std::f64::consts::TAU),
            overshoot_c: uni(rng, 0.3, 1.5),
            overshoot_tau_s: uni(rng, 180.0, 600.0),
        });
        Chamber {
            profile,
            lo_c: lo,
            hi_c: hi,
            duration_s,
            air_tau_s,
            hunting,
            knots,
            events,
        }
    }

    /// The setpoint at `t_s` (before the record: its first value).
    pub(super) fn setpoint(&self, t_s: f64) -> f64 {
        let t = t_s.max(0.0);
        let v = match &self.profile {
            Profile::Sine {
                period_s,
                phase_rad,
            } => {
                let (mid, amp) = (0.5 * (self.lo_c + self.hi_c), 0.5 * (self.hi_c - self.lo_c));
                mid + amp * (std::f64::consts::TAU * t / period_s + phase_rad).sin()
            }
            _ => {
                let k = &self.knots;
                let j = k.partition_point(|p| p.0 <= t);
                if j == 0 {
                    k[0].1
                } else if j == k.len() {
                    k[k.len() - 1].1
                } else {
                    let ((t0, v0), (t1, v1)) = (k[j - 1], k[j]);
                    v0 + (v1 - v0) * (t - t0) / (t1 - t0)
                }
            }
        };
        v.clamp(CHAMBER_MIN_C, CHAMBER_MAX_C)
    }

    /// The controller's error on the air at `t_s`: hunting plus the overshoot bumps
    /// x·e^(1−x), x = (t − t_end)/τ, after every ramp or step.
    fn control_error(&self, t_s: f64) -> f64 {
        let Some(h) = &self.hunting else { return 0.0 };
        let hunt = h.amplitude_c * (std::f64::consts::TAU * t_s / h.period_s + h.phase_rad).sin();
        let over: f64 = self
            .events
            .iter()
            .filter(|(te, _)| t_s >= *te && t_s - te < 30.0 * h.overshoot_tau_s)
            .map(|(te, dir)| {
                let x = (t_s - te) / h.overshoot_tau_s;
                dir * h.overshoot_c * x * (1.0 - x).exp()
            })
            .sum();
        hunt + over
    }
}

/// The gyro body: case and core nodes, self-heating, power-on time, where the sensor sits.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Body {
    /// Lag of the case behind the air, s.
    pub tau_case_s: f64,
    /// Lag of the core behind the case, s.
    pub tau_core_s: f64,
    /// Final rise of the body over the air from its own dissipation, °C.
    pub heat_c: f64,
    /// Time constant of that rise, s.
    pub heat_tau_s: f64,
    /// Time from power-on to the record's first sample, s (0: the record starts cold).
    pub warm_s: f64,
    /// The temperature sensor (and the bias physics) sits on the core; else on the case.
    pub sensor_on_core: bool,
}

impl Body {
    /// Draws a body (see the module doc of `mismatch`).
    pub(super) fn draw(rng: &mut ChaCha8Rng) -> Body {
        Body {
            tau_case_s: uni(rng, 300.0, 1500.0),
            tau_core_s: uni(rng, 800.0, 4000.0),
            heat_c: uni(rng, 1.0, 6.0),
            heat_tau_s: log_uni(rng, 1500.0, 5000.0),
            warm_s: if uni(rng, 0.0, 1.0) < 0.3 {
                (uni(rng, 2.0, 8.0) * 3600.0).round()
            } else {
                0.0
            },
            sensor_on_core: uni(rng, 0.0, 1.0) < 0.5,
        }
    }
}

/// The thermal history at the record's samples.
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// s, from 0.
    pub t_s: Vec<f64>,
    /// Chamber air, °C.
    pub air_c: Vec<f64>,
    /// Temperature of the sensor's node, °C.
    pub node_c: Vec<f64>,
    /// Its time derivative, °C/s (from the model's equations, not a difference).
    pub dnode_c_per_s: Vec<f64>,
    /// Temperature of the body's other node (the core when the sensor is on the case, the
    /// case when it is on the core), °C.
    pub other_c: Vec<f64>,
    /// Its time derivative, °C/s.
    pub dother_c_per_s: Vec<f64>,
}

impl Trajectory {
    /// The same history with the other node in the sensor node's place: what an effect of
    /// that node sees.
    pub fn at_other_node(&self) -> Trajectory {
        Trajectory {
            t_s: self.t_s.clone(),
            air_c: self.air_c.clone(),
            node_c: self.other_c.clone(),
            dnode_c_per_s: self.dother_c_per_s.clone(),
            other_c: self.node_c.clone(),
            dother_c_per_s: self.dnode_c_per_s.clone(),
        }
    }
}

/// Runs the chamber and body: air τ_a·ȧ = SP − a (plus the control error), case
/// τ_c·ċ = air + S(t) − c, core τ_k·k̇ = c − k, S(t) = heat·(1 − e^(−(t − t_on)/τ_h)) after
/// power-on. RK4 at `dt_s` (every time constant is ≥ 120 s); a warm record runs from
/// power-on, `warm_s` before its first sample, at the first setpoint.
pub fn run(chamber: &Chamber, body: &Body, dt_s: f64) -> Trajectory {
    let t_on = -body.warm_s;
    let air = |t: f64, y0: f64| y0 + chamber.control_error(t);
    let rhs = |t: f64, y: [f64; 3]| -> [f64; 3] {
        let heat = if t >= t_on {
            body.heat_c * (1.0 - (-(t - t_on) / body.heat_tau_s).exp())
        } else {
            0.0
        };
        [
            (chamber.setpoint(t) - y[0]) / chamber.air_tau_s,
            (air(t, y[0]) + heat - y[1]) / body.tau_case_s,
            (y[1] - y[2]) / body.tau_core_s,
        ]
    };
    let step = |t: f64, y: [f64; 3]| -> [f64; 3] {
        let add =
            |y: [f64; 3], k: [f64; 3], h: f64| [y[0] + h * k[0], y[1] + h * k[1], y[2] + h * k[2]];
        let k1 = rhs(t, y);
        let k2 = rhs(t + 0.5 * dt_s, add(y, k1, 0.5 * dt_s));
        let k3 = rhs(t + 0.5 * dt_s, add(y, k2, 0.5 * dt_s));
        let k4 = rhs(t + dt_s, add(y, k3, dt_s));
        std::array::from_fn(|i| y[i] + dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    };
    let s0 = chamber.setpoint(0.0);
    let mut y = [s0; 3];
    let pre = (body.warm_s / dt_s).round() as usize;
    for i in 0..pre {
        y = step(t_on + i as f64 * dt_s, y);
    }
    let n = (chamber.duration_s / dt_s).round() as usize;
    let (node, other) = if body.sensor_on_core { (2, 1) } else { (1, 2) };
    let mut out = Trajectory {
        t_s: Vec::with_capacity(n),
        air_c: Vec::with_capacity(n),
        node_c: Vec::with_capacity(n),
        dnode_c_per_s: Vec::with_capacity(n),
        other_c: Vec::with_capacity(n),
        dother_c_per_s: Vec::with_capacity(n),
    };
    for i in 0..n {
        let t = i as f64 * dt_s;
        if i > 0 {
            y = step(t - dt_s, y);
        }
        out.t_s.push(t);
        out.air_c.push(air(t, y[0]));
        let dy = rhs(t, y);
        out.node_c.push(y[node]);
        out.dnode_c_per_s.push(dy[node]);
        out.other_c.push(y[other]);
        out.dother_c_per_s.push(dy[other]);
    }
    out
}

/// One line on the chamber: profile, range, length and control.
pub(super) fn describe_chamber(c: &Chamber) -> String {
    let p = match &c.profile {
        Profile::Ramp {
            rate_c_per_min,
            cycles,
            hold_s,
            from_top,
        } => format!(
            "{rate_c_per_min} °C/min {:.0}..{:.0} °C, {cycles} cycles{}, holds {:.1} h",
            c.lo_c,
            c.hi_c,
            if *from_top { " from the top" } else { "" },
            hold_s / 3600.0
        ),
        Profile::Sine { period_s, .. } => format!(
            "day/night sine {:.1} h {:.0}..{:.0} °C",
            period_s / 3600.0,
            c.lo_c,
            c.hi_c
        ),
        Profile::Staircase { soak_s, levels } => format!(
            "15 °C staircase {:.0}..{:.0} °C ({levels} levels), soaks {:.1} h",
            c.lo_c,
            c.hi_c,
            soak_s / 3600.0
        ),
    };
    let ctl = match &c.hunting {
        Some(h) => format!(
            ", PID hunting ±{:.2} °C/{:.0} min, overshoot {:.1} °C",
            h.amplitude_c,
            h.period_s / 60.0,
            h.overshoot_c
        ),
        None => String::new(),
    };
    format!(
        "{p}, {:.1} h; air τ {:.0} s{ctl}",
        c.duration_s / 3600.0,
        c.air_tau_s
    )
}

/// One line on the body.
pub(super) fn describe_body(b: &Body) -> String {
    format!(
        "two-node τ {:.0}/{:.0} s, sensor on {}, self-heating {:.1} °C/{:.0} s, {}",
        b.tau_case_s,
        b.tau_core_s,
        if b.sensor_on_core { "core" } else { "case" },
        b.heat_c,
        b.heat_tau_s,
        if b.warm_s > 0.0 {
            format!("warm start {:.1} h", b.warm_s / 3600.0)
        } else {
            "cold start".to_string()
        }
    )
}
