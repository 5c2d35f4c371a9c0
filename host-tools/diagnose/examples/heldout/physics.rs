//! The held-out generator's own physics: the two plants as explicit ODEs, the element and
//! input effect laws, and a fixed-step RK4 integration (10 kHz) sampled at 1 kHz.
//!
//! Written from the equations of the brief only; nothing here comes from `mil-diagnose`'s
//! effect laws or simulator, nor from `mil-rig`'s plant.
//!
//! Conventions (those of the model schema): an element's compression is
//! `x = pos(lower) − pos(upper)`, its force `F` pushes its ends apart, so `+F` acts on the
//! upper end and `−F` on the lower one. Positions and forces are deviations from the static
//! equilibrium (gravity balanced), except in the tyre's lift-off law, which needs the
//! static wheel load.

/// Internal integration rate (Hz).
pub const SIM_RATE_HZ: f64 = 10_000.0;
/// Rate of the input grid (Hz): twice the integration rate, so that RK4's half steps fall on
/// input samples.
pub const INPUT_RATE_HZ: f64 = 2.0 * SIM_RATE_HZ;
/// Output (record) rate (Hz).
pub const OUT_RATE_HZ: f64 = 1_000.0;
/// Internal steps per record sample.
pub const STEPS_PER_SAMPLE: usize = (SIM_RATE_HZ / OUT_RATE_HZ) as usize;
/// Input-grid samples per record sample.
pub const FINE_PER_SAMPLE: usize = 2 * STEPS_PER_SAMPLE;
/// Gravity (m/s²), for the tyre's static load.
pub const GRAVITY: f64 = 9.81;

/// The true linear plant.
#[derive(Clone, Copy, Debug)]
pub enum Plant {
    /// Quarter car on a road: body `x_s` on the suspension, hub `x_u` on the tyre, the
    /// road a prescribed displacement under the tyre.
    QuarterCar {
        /// Sprung mass (kg).
        m_s: f64,
        /// Unsprung mass (kg).
        m_u: f64,
        /// Suspension stiffness (N/m).
        k_c: f64,
        /// Suspension damping (N s/m).
        c_c: f64,
        /// Tyre stiffness (N/m).
        k_t: f64,
        /// Tyre damping (N s/m).
        c_t: f64,
    },
    /// A mass on a spring-damper to ground, driven by a force.
    Sdof {
        /// Mass (kg).
        m: f64,
        /// Stiffness (N/m).
        k: f64,
        /// Damping (N s/m).
        c: f64,
    },
}

impl Plant {
    /// Stiffness and damping of the element that carries the element effects.
    pub fn effect_element_kc(&self) -> (f64, f64) {
        match *self {
            Plant::QuarterCar { k_c, c_c, .. } => (k_c, c_c),
            Plant::Sdof { k, c, .. } => (k, c),
        }
    }

    /// Mass seen by the relative motion across the effect element (kg).
    fn relative_mass(&self) -> f64 {
        match *self {
            Plant::QuarterCar { m_s, m_u, .. } => m_s * m_u / (m_s + m_u),
            Plant::Sdof { m, .. } => m,
        }
    }

    /// Static load of the tyre (N) (quarter car; 0 otherwise).
    pub fn static_tyre_load(&self) -> f64 {
        match *self {
            Plant::QuarterCar { m_s, m_u, .. } => (m_s + m_u) * GRAVITY,
            Plant::Sdof { .. } => 0.0,
        }
    }
}

/// An effect in the effect element (`suspension` or `spring`).
#[derive(Clone, Copy, Debug)]
pub enum ElementEffect {
    /// Spring force `k x + k3 x³`.
    Cubic {
        /// N/m³ (> 0 hardening).
        k3: f64,
    },
    /// Dry friction `F_c sign(v)`, regularised by a steep linear ramp within `±v_eps` whose
    /// slope is set by the integration step (see [`simulate`]).
    Coulomb {
        /// N.
        fc: f64,
    },
    /// Dry friction through a compliant contact (Dahl): friction force `F` with
    /// `dF/dt = σ v (1 − F/F_c sign(v))`.
    Dahl {
        /// N.
        fc: f64,
        /// Contact stiffness (N/m).
        sigma: f64,
    },
    /// End stop(s): `k_b (x − gap)` for `x > gap`, `k_b (x + rebound_gap)` for
    /// `x < −rebound_gap`.
    BumpStop {
        /// N/m.
        k_b: f64,
        /// Compression-side gap (m).
        gap: Option<f64>,
        /// Extension-side gap (m).
        rebound_gap: Option<f64>,
    },
    /// Free play of half gap `b` in the spring path: `k (x − clamp(x, −b, b))`.
    Backlash {
        /// m.
        b: f64,
    },
    /// `c2 v |v|` added to the damper.
    Quadratic {
        /// N s²/m².
        c2: f64,
    },
    /// Damping `c_bump` for `v > 0`, `c_rebound` for `v < 0`, instead of `c`.
    Asymmetric {
        /// N s/m.
        c_bump: f64,
        /// N s/m.
        c_rebound: f64,
    },
    /// Bouc-Wen: spring force `α k x + (1 − α) k z`, `z' = v − β |v| z − γ v |z|`.
    BoucWen {
        /// Fraction of the stiffness that stays elastic.
        alpha: f64,
        /// 1/m.
        beta: f64,
        /// 1/m.
        gamma: f64,
    },
}

/// An effect on the input between the logged column and the plant.
#[derive(Clone, Copy, Debug)]
pub enum InputEffect {
    /// `u(t − τ)`.
    Delay {
        /// s.
        tau: f64,
    },
    /// `|du/dt| <= r`.
    RateLimit {
        /// Input unit per s.
        rate: f64,
    },
    /// `clamp(u, lower, upper)`.
    Saturation {
        /// Input unit.
        lower: f64,
        /// Input unit.
        upper: f64,
    },
    /// Play operator of half gap `b` (a displacement input's linkage).
    Play {
        /// m.
        half_gap: f64,
    },
}

/// The effects hidden in one simulation.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hidden {
    /// In the effect element.
    pub element: Option<ElementEffect>,
    /// On the input.
    pub input: Option<InputEffect>,
    /// The tyre can only push (quarter car).
    pub lift_off: bool,
}

/// A simulation sampled at the record rate.
#[derive(Clone, Debug)]
pub struct SimOut {
    /// Quarter car: `x_s`, `x_u`, tyre force, body acceleration; sdof: `x`.
    pub outputs: Vec<Vec<f64>>,
    /// Compression of the effect element (m).
    pub compression: Vec<f64>,
    /// Its rate (m/s).
    pub rate: Vec<f64>,
    /// Fraction of record samples with the tyre off the road.
    pub airborne: f64,
}

/// The input as the plant sees it (on the input grid of step `h`).
pub fn apply_input_effect(u: &[f64], h: f64, effect: Option<InputEffect>) -> Vec<f64> {
    match effect {
        None => u.to_vec(),
        Some(InputEffect::Delay { tau }) => {
            let shift = tau / h;
            (0..u.len())
                .map(|i| {
                    let t = i as f64 - shift;
                    if t <= 0.0 {
                        u[0]
                    } else {
                        let j = t.floor() as usize;
                        let f = t - j as f64;
                        let a = u[j];
                        let b = u.get(j + 1).copied().unwrap_or(a);
                        a + f * (b - a)
                    }
                })
                .collect()
        }
        Some(InputEffect::RateLimit { rate }) => {
            let step = rate * h;
            let mut y = Vec::with_capacity(u.len());
            let mut prev = u.first().copied().unwrap_or(0.0);
            for &v in u {
                prev += (v - prev).clamp(-step, step);
                y.push(prev);
            }
            y
        }
        Some(InputEffect::Saturation { lower, upper }) => {
            u.iter().map(|v| v.clamp(lower, upper)).collect()
        }
        Some(InputEffect::Play { half_gap }) => {
            let mut y = Vec::with_capacity(u.len());
            let mut prev = u.first().copied().unwrap_or(0.0);
            for &v in u {
                prev = prev.clamp(v - half_gap, v + half_gap);
                y.push(prev);
            }
            y
        }
    }
}

/// Central-difference derivative on a uniform grid of step `h`.
fn derivative(u: &[f64], h: f64) -> Vec<f64> {
    let n = u.len();
    (0..n)
        .map(|i| {
            if n < 2 {
                0.0
            } else if i == 0 {
                (u[1] - u[0]) / h
            } else if i == n - 1 {
                (u[n - 1] - u[n - 2]) / h
            } else {
                (u[i + 1] - u[i - 1]) / (2.0 * h)
            }
        })
        .collect()
}

/// Force of the effect element and the rate of its internal state `z`.
fn element_force(
    k: f64,
    c: f64,
    effect: Option<ElementEffect>,
    v_eps: f64,
    x: f64,
    v: f64,
    z: f64,
) -> (f64, f64) {
    match effect {
        None => (k * x + c * v, 0.0),
        Some(ElementEffect::Cubic { k3 }) => (k * x + k3 * x * x * x + c * v, 0.0),
        Some(ElementEffect::Coulomb { fc }) => {
            (k * x + c * v + fc * (v / v_eps).clamp(-1.0, 1.0), 0.0)
        }
        Some(ElementEffect::Dahl { fc, sigma }) => {
            let s = if v > 0.0 {
                1.0
            } else if v < 0.0 {
                -1.0
            } else {
                0.0
            };
            (k * x + c * v + z, sigma * v * (1.0 - z / fc * s))
        }
        Some(ElementEffect::BumpStop {
            k_b,
            gap,
            rebound_gap,
        }) => {
            let mut f = k * x + c * v;
            if let Some(g) = gap {
                f += k_b * (x - g).max(0.0);
            }
            if let Some(g) = rebound_gap {
                f += k_b * (x + g).min(0.0);
            }
            (f, 0.0)
        }
        Some(ElementEffect::Backlash { b }) => (k * (x - x.clamp(-b, b)) + c * v, 0.0),
        Some(ElementEffect::Quadratic { c2 }) => (k * x + c * v + c2 * v * v.abs(), 0.0),
        Some(ElementEffect::Asymmetric { c_bump, c_rebound }) => {
            (k * x + if v > 0.0 { c_bump } else { c_rebound } * v, 0.0)
        }
        Some(ElementEffect::BoucWen { alpha, beta, gamma }) => (
            alpha * k * x + (1.0 - alpha) * k * z + c * v,
            v - beta * v.abs() * z - gamma * v * z.abs(),
        ),
    }
}

/// State: `[x_s, v_s, x_u, v_u, z]` (quarter car) or `[x, v, 0, 0, z]` (sdof).
type State = [f64; 5];

struct Rhs {
    plant: Plant,
    hidden: Hidden,
    v_eps: f64,
    preload: f64,
}

/// Derivative, plus (tyre force, body acceleration, tyre off the road).
impl Rhs {
    fn eval(&self, s: &State, u: f64, ud: f64) -> (State, f64, f64, bool) {
        match self.plant {
            Plant::QuarterCar {
                m_s,
                m_u,
                k_c,
                c_c,
                k_t,
                c_t,
            } => {
                let (f_s, zd) = element_force(
                    k_c,
                    c_c,
                    self.hidden.element,
                    self.v_eps,
                    s[2] - s[0],
                    s[3] - s[1],
                    s[4],
                );
                let dynamic = k_t * (u - s[2]) + c_t * (ud - s[3]);
                let (f_t, off) = if self.hidden.lift_off {
                    let total = self.preload + dynamic;
                    (total.max(0.0) - self.preload, total < 0.0)
                } else {
                    (dynamic, false)
                };
                let a_s = f_s / m_s;
                let a_u = (f_t - f_s) / m_u;
                ([s[1], a_s, s[3], a_u, zd], f_t, a_s, off)
            }
            Plant::Sdof { m, k, c } => {
                let (f, zd) =
                    element_force(k, c, self.hidden.element, self.v_eps, -s[0], -s[1], s[4]);
                let a = (f + u) / m;
                ([s[1], a, 0.0, 0.0, zd], 0.0, a, false)
            }
        }
    }
}

fn axpy(s: &State, h: f64, d: &State) -> State {
    let mut r = *s;
    for (ri, di) in r.iter_mut().zip(d) {
        *ri += h * di;
    }
    r
}

/// Simulates `plant` with `hidden` from rest at equilibrium, driven by the logged input
/// `u_fine` (on the input grid, `FINE_PER_SAMPLE · (n_out − 1) + 1` samples), and samples
/// it at the record rate (`n_out` samples).
///
/// # Errors
/// The input grid has the wrong length, or the simulation diverged.
pub fn simulate(
    plant: &Plant,
    hidden: &Hidden,
    u_fine: &[f64],
    n_out: usize,
) -> Result<SimOut, String> {
    if n_out < 2 || u_fine.len() != FINE_PER_SAMPLE * (n_out - 1) + 1 {
        return Err(format!(
            "input grid of {} samples for {n_out} record samples",
            u_fine.len()
        ));
    }
    let h_in = 1.0 / INPUT_RATE_HZ;
    let h = 1.0 / SIM_RATE_HZ;
    let u = apply_input_effect(u_fine, h_in, hidden.input);
    let ud = derivative(&u, h_in);
    // Coulomb regularisation: the ramp's slope F_c / v_eps acting on the relative mass has
    // λ·h = 1, well inside RK4's stability limit (2.78), as steep as the step allows.
    let v_eps = match hidden.element {
        Some(ElementEffect::Coulomb { fc }) => (fc * h / plant.relative_mass()).max(1e-12),
        _ => 1.0,
    };
    let rhs = Rhs {
        plant: *plant,
        hidden: *hidden,
        v_eps,
        preload: plant.static_tyre_load(),
    };
    let n_outputs = match plant {
        Plant::QuarterCar { .. } => 4,
        Plant::Sdof { .. } => 1,
    };
    let mut outputs = vec![Vec::with_capacity(n_out); n_outputs];
    let mut compression = Vec::with_capacity(n_out);
    let mut rate = Vec::with_capacity(n_out);
    let mut airborne = 0usize;
    let mut s: State = [0.0; 5];
    let mut sample = |s: &State, i: usize| -> Result<(), String> {
        let j = i * FINE_PER_SAMPLE;
        let (_, f_t, a, off) = rhs.eval(s, u[j], ud[j]);
        if s.iter().any(|v| !v.is_finite() || v.abs() > 1e3) {
            return Err(format!("diverged at t = {:.3} s", i as f64 / OUT_RATE_HZ));
        }
        match plant {
            Plant::QuarterCar { .. } => {
                outputs[0].push(s[0]);
                outputs[1].push(s[2]);
                outputs[2].push(f_t);
                outputs[3].push(a);
                compression.push(s[2] - s[0]);
                rate.push(s[3] - s[1]);
            }
            Plant::Sdof { .. } => {
                outputs[0].push(s[0]);
                compression.push(-s[0]);
                rate.push(-s[1]);
            }
        }
        if off {
            airborne += 1;
        }
        Ok(())
    };
    sample(&s, 0)?;
    for i in 1..n_out {
        for step in 0..STEPS_PER_SAMPLE {
            let j = (i - 1) * FINE_PER_SAMPLE + 2 * step;
            let (k1, ..) = rhs.eval(&s, u[j], ud[j]);
            let (k2, ..) = rhs.eval(&axpy(&s, 0.5 * h, &k1), u[j + 1], ud[j + 1]);
            let (k3, ..) = rhs.eval(&axpy(&s, 0.5 * h, &k2), u[j + 1], ud[j + 1]);
            let (k4, ..) = rhs.eval(&axpy(&s, h, &k3), u[j + 2], ud[j + 2]);
            for q in 0..5 {
                s[q] += h / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q]);
            }
        }
        sample(&s, i)?;
    }
    Ok(SimOut {
        outputs,
        compression,
        rate,
        airborne: airborne as f64 / n_out as f64,
    })
}
