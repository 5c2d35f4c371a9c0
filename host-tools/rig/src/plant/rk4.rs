//! Advancing the plant in time ([`Plant::advance`]): the whole control period in one
//! product of the exact model when the last sample allows it, else internal steps, each an
//! exact step while the state stays in the linear regime and a classical fourth-order
//! Runge–Kutta step otherwise, with the demand held and the road ramping linearly.

use super::drive::drive_actuators;
use super::linear::{with_linear, Linear};
use super::Plant;

impl Plant {
    fn set_road(&mut self, from: &[f64], to: &[f64], fraction: f64, duration_s: f64) {
        for ((r, rr), (a, b)) in self
            .road
            .iter_mut()
            .zip(self.road_rate.iter_mut())
            .zip(from.iter().zip(to))
        {
            *r = a + fraction * (b - a);
            *rr = (b - a) / duration_s;
        }
    }

    /// Advances by `duration_s` (s) in RK4 steps of at most the internal step, with the
    /// actuator demands `demand` (N per channel; ignored by an ideal interface) held and the
    /// road ramping from `road_from` to `road_to` (m per input). A piecewise-linear plant
    /// takes the same steps exactly while in its linear regime (see the [`plant`](super)
    /// module documentation); after a [`Plant::sample`] in the regime with the same demand and
    /// `road_from`, the whole period is one matrix-vector product.
    ///
    /// When [`Plant::sample`] was called last with the same demand, `road_from` and the
    /// ramp's rate `(road_to − road_from) / duration_s` (m/s), the first RK4 stage is the
    /// derivative it evaluated and is not evaluated again.
    pub fn advance(&mut self, duration_s: f64, demand: &[f64], road_from: &[f64], road_to: &[f64]) {
        self.linear_outputs = false;
        if self.exact_steps {
            if let Some(linear) = self.linear.as_mut() {
                let actuators = drive_actuators(&self.drive);
                let state = &mut self.state;
                let steps = with_linear!(linear, m => m.advance_period(
                    state,
                    actuators,
                    demand,
                    (road_from, road_to),
                    duration_s,
                )
                .then_some(m.fused_steps));
                if let Some(steps) = steps {
                    self.counts.exact += steps as u64;
                    self.time_s += duration_s;
                    return;
                }
            }
        }
        self.advance_in_steps(duration_s, demand, road_from, road_to);
    }

    /// [`Plant::advance`] step by step: exact internal steps while in the regime, RK4
    /// otherwise (and everywhere without exact steps).
    #[inline(never)]
    fn advance_in_steps(
        &mut self,
        duration_s: f64,
        demand: &[f64],
        road_from: &[f64],
        road_to: &[f64],
    ) {
        if self.advance_split.0 != duration_s {
            let steps = (duration_s / self.internal_step_s - 1e-9).ceil().max(1.0) as usize;
            self.advance_split = (duration_s, steps, duration_s / steps as f64);
        }
        let (_, steps, h) = self.advance_split;
        let mut exact = false;
        if self.exact_steps {
            if let Some(linear) = self.linear.as_mut() {
                let (ready, rows) = with_linear!(&*linear, m => (
                    m.step_s == h && m.period_s == duration_s,
                    m.parts.fused_rows(steps),
                ));
                if !ready && rows > linear.capacity() {
                    // A period of more internal steps than the fused matrix has room for:
                    // widen it (allocates; only when the period changes).
                    let parts = with_linear!(&*linear, m => m.parts.clone());
                    if let Some(wider) = Linear::with_rows(parts, rows) {
                        *linear = wider;
                    }
                }
                exact = ready || with_linear!(linear, m => m.discretise(duration_s, steps));
            }
        }
        let mut previous_exact = false;
        for s in 0..steps {
            if exact {
                if let Some(linear) = self.linear.as_mut() {
                    let f0 = if s == 0 { 0.0 } else { s as f64 / steps as f64 };
                    let actuators = drive_actuators(&self.drive);
                    let state = &mut self.state;
                    // After an exact step the start was tested as that step's end.
                    let done = with_linear!(linear, m => m.step(
                        state,
                        actuators,
                        demand,
                        (road_from, road_to),
                        f0,
                        duration_s,
                        previous_exact,
                    ));
                    previous_exact = done;
                    if done {
                        self.counts.exact += 1;
                        continue;
                    }
                }
            }
            self.rk4_step(s, steps, h, demand, road_from, road_to, duration_s);
        }
        self.first_stage_ready = false;
        self.time_s += duration_s;
    }

    /// RK4 step `s` of `steps` (each `h`, s) of [`Plant::advance`].
    #[allow(clippy::too_many_arguments)]
    fn rk4_step(
        &mut self,
        s: usize,
        steps: usize,
        h: f64,
        demand: &[f64],
        road_from: &[f64],
        road_to: &[f64],
        duration_s: f64,
    ) {
        let f0 = s as f64 / steps as f64;
        let fm = (s as f64 + 0.5) / steps as f64;
        let f1 = (s as f64 + 1.0) / steps as f64;
        self.set_road(road_from, road_to, f0, duration_s);
        let reuse = s == 0
            && self.first_stage_ready
            && self.sampled_demand == demand
            && self.sampled_road == self.road
            && self.sampled_road_rate == self.road_rate;
        if !reuse {
            self.derivative(0, false, demand);
        }
        self.set_road(road_from, road_to, fm, duration_s);
        let half = 0.5 * h;
        stage(&mut self.tmp, &self.state, &self.k[0], half);
        self.derivative(1, true, demand);
        stage(&mut self.tmp, &self.state, &self.k[1], half);
        self.derivative(2, true, demand);
        self.set_road(road_from, road_to, f1, duration_s);
        stage(&mut self.tmp, &self.state, &self.k[2], h);
        self.derivative(3, true, demand);
        let sixth = h / 6.0;
        let [k0, k1, k2, k3] = &self.k;
        for ((x, a), ((b, c), d)) in self.state.iter_mut().zip(k0).zip(k1.iter().zip(k2).zip(k3)) {
            *x += sixth * (a + 2.0 * b + 2.0 * c + d);
        }
        self.first_stage_ready = false;
        self.counts.rk4 += 1;
    }
}

/// `tmp = x + h k` (an RK4 trial state).
#[inline]
fn stage(tmp: &mut [f64], x: &[f64], k: &[f64], h: f64) {
    for ((t, a), b) in tmp.iter_mut().zip(x).zip(k) {
        *t = a + h * b;
    }
}
