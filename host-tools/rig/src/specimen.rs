//! Specimens: mass-spring-damper structures made of rigid DOFs and force elements, with the
//! actuators' attachment points and the road inputs.
//!
//! A specimen has `n` generalised DOFs `q` (m or rad, deviations from the static
//! equilibrium), a constant mass matrix `M`, force elements ([`mil_structure::Element`])
//! and constant generalised static forces `g` (gravity). Element `e` is placed by two
//! coefficient vectors: its compression is `x_e = a_e · q + b_e · w` (m) with `w` the road
//! inputs (m), its compression rate `a_e · q̇ + b_e · ẇ`, and its force `F_e` (pushing its
//! ends apart) acts on the DOFs as the generalised force `−a_e F_e` (virtual work). Interface
//! channel `j` (an actuator) is attached at the point `y_j = t_j · q` (m, the actuator's
//! positive direction) and applies `t_j F_j`. Hence
//!
//! ```text
//! M q̈ = g − Σ_e a_e F_e(x_e, ẋ_e) + Σ_j t_j F_j
//! ```
//!
//! Static equilibrium: at `q = 0`, `w = 0` the element preloads, the static forces and the
//! static actuator forces (the numerical model's static demand) balance; the built-in
//! specimens are set up so.
//!
//! Built in: the paper's quarter car on a hub-coupled rig ([`Specimen::quarter_car`]) and
//! its half car on a four-poster with down-force actuators ([`Specimen::half_car`]); any
//! other structure can be described directly (a general mass-spring-damper specimen).

use mil_params::{AeroExample, TyreExample};
use mil_structure::model::InputKind;
use mil_structure::{Element, Model};
use serde::{Deserialize, Serialize};

/// Standard gravity (m/s²).
pub const GRAVITY_M_PER_S2: f64 = 9.81;

/// How far (relative to the weights) the board's static demand may be off what holds a
/// specimen at rest ([`Specimen::check_near_rest`]): `f32` rounding and a fitted load's last
/// digits (0.1 %: 1.7 N on the paper's quarter car, which the rig takes up by settling 7 µm
/// on the tyre's stiffness); a load in kg or lb is far off.
pub const STATIC_DEMAND_TOLERANCE: f64 = 1e-3;

/// A force element and where it sits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlacedElement {
    /// Name, for reports (e.g. "suspension").
    pub name: String,
    /// The element's force law and switchable effects.
    pub element: Element,
    /// `a_e`: compression per unit of each DOF (m/m or m/rad).
    pub dof_coefficients: Vec<f64>,
    /// `b_e`: compression per unit of each road input (m/m).
    pub input_coefficients: Vec<f64>,
}

/// A specimen (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Specimen {
    /// DOF names.
    pub dofs: Vec<String>,
    /// Mass matrix, rows (kg, kg·m²).
    pub mass: Vec<Vec<f64>>,
    /// Generalised static forces `g` per DOF (N, N·m), e.g. gravity.
    pub static_force: Vec<f64>,
    /// Force elements.
    pub elements: Vec<PlacedElement>,
    /// Road input names (m).
    pub inputs: Vec<String>,
    /// Attachment `t_j` of each interface channel (actuator): `y_j = t_j · q`.
    pub attachments: Vec<Vec<f64>>,
}

/// Errors of a specimen description.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("specimen: {0}")]
pub struct SpecimenError(pub String);

impl Specimen {
    /// The quarter car of the tyre example on a hub-coupled rig: DOFs `x_s` (body) and
    /// `x_u` (hub), the suspension between them (preloaded by the body's weight), gravity on
    /// both masses, one actuator on the hub carrying the car's weight `(m_s + m_u) g` (the
    /// tyre model's static load). The tyre is the numerical model's, so the road drives only
    /// the model: the specimen has no road input.
    pub fn quarter_car(car: &TyreExample, suspension: Element) -> Self {
        let g = GRAVITY_M_PER_S2;
        Self {
            dofs: vec!["x_s".into(), "x_u".into()],
            mass: vec![
                vec![car.sprung_mass_kg, 0.0],
                vec![0.0, car.unsprung_mass_kg],
            ],
            static_force: vec![-car.sprung_mass_kg * g, -car.unsprung_mass_kg * g],
            elements: vec![PlacedElement {
                name: "suspension".into(),
                element: Element {
                    preload_n: car.sprung_mass_kg * g,
                    ..suspension
                },
                // Compression: the hub rising towards the body.
                dof_coefficients: vec![-1.0, 1.0],
                input_coefficients: vec![],
            }],
            inputs: vec![],
            attachments: vec![vec![0.0, 1.0]],
        }
    }

    /// The specimen of a structure file ([`mil_structure::Model`]): its DOFs and masses, its
    /// weights as static forces, its elements with their laws, effects and preloads, its
    /// displacement inputs as road inputs, and one actuator per entry of `attach`, driving
    /// that DOF or point along its positive direction. A DOF's `bias_n` (the constant offset
    /// a record's fit carries, e.g. a load cell's zero error) is not a load on the rig and is
    /// left out: the specimen starts at rest at its equilibrium.
    ///
    /// # Errors
    /// An attachment that is no DOF or point, an input effect (the rig simulates element
    /// effects; an input's delay or limits belong to what drives it).
    pub fn from_structure(model: &Model, attach: &[String]) -> Result<Self, SpecimenError> {
        let displacement: Vec<usize> = (0..model.inputs.len())
            .filter(|&j| model.inputs[j].kind == InputKind::Displacement)
            .collect();
        if let Some(i) = model.inputs.iter().find(|i| !i.law.kinds().is_empty()) {
            return Err(SpecimenError(format!(
                "input {:?} has effects ({:?}): the rig simulates element effects only",
                i.name,
                i.law.kinds()
            )));
        }
        let attachments = attach
            .iter()
            .map(|name| {
                model.position_of(name).ok_or_else(|| {
                    SpecimenError(format!(
                        "attachment {name:?} is no DOF or point of the structure (DOFs: {:?})",
                        model.dofs
                    ))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            dofs: model.dofs.clone(),
            mass: (0..model.n())
                .map(|i| {
                    (0..model.n())
                        .map(|j| if i == j { model.mass[i] } else { 0.0 })
                        .collect()
                })
                .collect(),
            static_force: model.static_force.clone(),
            elements: model
                .elements
                .iter()
                .map(|e| PlacedElement {
                    name: e.name.clone(),
                    element: Element::from_law(&e.law, e.preload_n),
                    dof_coefficients: e.a.clone(),
                    input_coefficients: displacement.iter().map(|&j| e.b[j]).collect(),
                })
                .collect(),
            inputs: displacement
                .iter()
                .map(|&j| model.inputs[j].name.clone())
                .collect(),
            attachments,
        })
    }

    /// The paper's suspension of the quarter car: linear `k_c`, `c_c` (effects off).
    pub fn quarter_car_suspension(car: &TyreExample) -> Element {
        Element::linear(car.suspension_stiffness, car.suspension_damping)
    }

    /// The aero example's half car on a four-poster: DOFs `z_b` (heave, m) and `theta_b`
    /// (pitch, rad, nose up positive), front and rear suspensions (wheel and tyre lumped, as
    /// in the paper) from the posts `road_front`, `road_rear` to the axle points
    /// `x_f = z − l_f θ`, `x_r = z + l_r θ`, preloaded by the static axle loads, gravity on
    /// the body, and down-force actuators at the axle points (attachments the rows of `L`).
    pub fn half_car(car: &AeroExample, front: Element, rear: Element) -> Self {
        let g = GRAVITY_M_PER_S2;
        let (lf, lr) = (car.front_axle_m, car.rear_axle_m);
        let weight = car.body_mass_kg * g;
        // Static axle loads of the body (centroid between the axles).
        let front_load = weight * lr / (lf + lr);
        let rear_load = weight * lf / (lf + lr);
        Self {
            dofs: vec!["z_b".into(), "theta_b".into()],
            mass: vec![
                vec![car.body_mass_kg, 0.0],
                vec![0.0, car.pitch_inertia_kg_m2],
            ],
            static_force: vec![-weight, 0.0],
            elements: vec![
                PlacedElement {
                    name: "front suspension".into(),
                    element: Element {
                        preload_n: front_load,
                        ..front
                    },
                    // Compression: the post rising towards the axle point.
                    dof_coefficients: vec![-1.0, lf],
                    input_coefficients: vec![1.0, 0.0],
                },
                PlacedElement {
                    name: "rear suspension".into(),
                    element: Element {
                        preload_n: rear_load,
                        ..rear
                    },
                    dof_coefficients: vec![-1.0, -lr],
                    input_coefficients: vec![0.0, 1.0],
                },
            ],
            inputs: vec!["road_front".into(), "road_rear".into()],
            attachments: vec![vec![1.0, -lf], vec![1.0, lr]],
        }
    }

    /// [`Specimen::half_car`] with the actuators holding `static_forces` (N, front and rear
    /// axle, up positive: a down force is negative) at rest: the suspensions' preloads carry
    /// the body's axle loads and `−static_forces`.
    pub fn half_car_holding(
        car: &AeroExample,
        front: Element,
        rear: Element,
        static_forces: [f64; 2],
    ) -> Self {
        let mut specimen = Self::half_car(car, front, rear);
        // half_car's elements: front suspension, then rear, under the attachments.
        for (e, f) in specimen.elements.iter_mut().zip(static_forces) {
            e.element.preload_n -= f;
        }
        specimen
    }

    /// The paper's half-car suspensions: linear front `(k_f, c_f)` and rear `(k_r, c_r)`.
    pub fn half_car_suspensions(car: &AeroExample) -> (Element, Element) {
        (
            Element::linear(car.front_stiffness, car.front_damping),
            Element::linear(car.rear_stiffness, car.rear_damping),
        )
    }

    /// Number of DOFs.
    pub fn len(&self) -> usize {
        self.dofs.len()
    }

    /// Whether the specimen has no DOFs.
    pub fn is_empty(&self) -> bool {
        self.dofs.is_empty()
    }

    /// The generalised force (N, N·m per DOF) left over at `q = 0`, `q̇ = 0` on a level road
    /// (`w = 0`) with the actuators applying `interface_forces` (N per attachment):
    /// `g − Σ_e a_e F_e(0, 0) + Σ_j t_j F_j`, element internal states at zero. Zero (to
    /// rounding) for a specimen at rest there (see the module documentation).
    pub fn static_imbalance(&self, interface_forces: &[f64]) -> Vec<f64> {
        let mut g = self.static_force.clone();
        for e in &self.elements {
            let f = e.element.force(0.0, 0.0, 0.0).unwrap_or(f64::NAN);
            for (gi, a) in g.iter_mut().zip(&e.dof_coefficients) {
                *gi -= a * f;
            }
        }
        for (t, f) in self.attachments.iter().zip(interface_forces) {
            for (gi, ti) in g.iter_mut().zip(t) {
                *gi += ti * f;
            }
        }
        g
    }

    /// Checks that the specimen is at rest at `q = 0` with the actuators applying
    /// `interface_forces` (N per attachment; zero: the substructure's static demand): every
    /// DOF's static imbalance within 1e-6 N (N·m) and 1e-6 of the static forces (the board
    /// holds its static demand in `f32`, a relative 6e-8).
    ///
    /// # Errors
    /// The first DOF out of balance, with its generalised force.
    pub fn check_at_rest(&self, interface_forces: &[f64]) -> Result<(), SpecimenError> {
        self.check_near_rest(interface_forces, 1e-6)
    }

    /// [`Specimen::check_at_rest`] within `relative` of the static forces (and 1e-6 N): a
    /// static demand a little off the weight (a fitted static load's last digits) that the
    /// rig takes up by settling.
    ///
    /// # Errors
    /// The first DOF out of balance, with its generalised force.
    pub fn check_near_rest(
        &self,
        interface_forces: &[f64],
        relative: f64,
    ) -> Result<(), SpecimenError> {
        let imbalance = self.static_imbalance(interface_forces);
        let tolerance = 1e-6 + relative * self.static_force.iter().map(|f| f.abs()).sum::<f64>();
        match imbalance
            .iter()
            .zip(&self.dofs)
            .find(|(f, _)| f.abs() > tolerance)
        {
            Some((f, dof)) => Err(SpecimenError(format!(
                "not at rest with {}: generalised force {f:.6} N on DOF {dof:?}; balance the \
                 static forces with the elements' preloads",
                if interface_forces.iter().all(|f| *f == 0.0) {
                    "zero actuator force".to_string()
                } else {
                    format!("the actuators' static forces {interface_forces:?} N")
                }
            ))),
            None => Ok(()),
        }
    }

    /// Checks dimensions, finiteness, a positive definite mass matrix and every element.
    ///
    /// # Errors
    /// The first problem, named.
    pub fn validate(&self) -> Result<(), SpecimenError> {
        let n = self.len();
        let err = |m: String| Err(SpecimenError(m));
        if n == 0 {
            return err("no DOFs".into());
        }
        if self.mass.len() != n || self.mass.iter().any(|r| r.len() != n) {
            return err(format!("mass must be {n} x {n}"));
        }
        if self.static_force.len() != n {
            return err(format!("static_force must have {n} entries"));
        }
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !self.mass.iter().all(|r| finite(r)) || !finite(&self.static_force) {
            return err("mass and static_force must be finite".into());
        }
        if mil_numerics::dense::invert(&self.mass).is_none() {
            return err("mass matrix must be positive definite".into());
        }
        for (i, row) in self.mass.iter().enumerate() {
            if row[i] <= 0.0 || (0..n).any(|j| row[j] != self.mass[j][i]) {
                return err("mass matrix must be symmetric with positive diagonal".into());
            }
        }
        for e in &self.elements {
            if e.dof_coefficients.len() != n || e.input_coefficients.len() != self.inputs.len() {
                return err(format!(
                    "element {:?}: {n} DOF and {} input coefficients needed",
                    e.name,
                    self.inputs.len()
                ));
            }
            if !finite(&e.dof_coefficients) || !finite(&e.input_coefficients) {
                return err(format!("element {:?}: non-finite coefficient", e.name));
            }
            e.element
                .validate()
                .map_err(|x| SpecimenError(format!("element {:?}: {x}", e.name)))?;
        }
        if self.attachments.is_empty() {
            return err("no actuator attachments".into());
        }
        for t in &self.attachments {
            if t.len() != n || !finite(t) || t.iter().all(|v| *v == 0.0) {
                return err(format!("attachments need {n} finite entries, not all zero"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in quarter car is at rest at `q = 0` with the actuator carrying its weight,
    /// and not without it.
    #[test]
    fn static_imbalance_of_the_quarter_car() {
        let car = TyreExample::default();
        let s = Specimen::quarter_car(&car, Specimen::quarter_car_suspension(&car));
        let weight = (car.sprung_mass_kg + car.unsprung_mass_kg) * GRAVITY_M_PER_S2;
        assert!(s.static_imbalance(&[weight]).iter().all(|f| f.abs() < 1e-9));
        let without = s.static_imbalance(&[0.0]);
        assert!(without[0].abs() < 1e-9, "{without:?}");
        assert!((without[1] + weight).abs() < 1e-9, "{without:?}");
    }

    /// A structure file becomes the specimen written by hand: the 2-DOF example's physical
    /// mass on its spring to the bed, gravity carried by the spring's preload.
    #[test]
    fn a_structure_file_is_the_specimen_written_out() {
        let model = Model::from_toml(
            r#"
name = "physical part"
gravity_m_per_s2 = 9.81
[[dof]]
name = "x_p"
mass = 5.0
[[element]]
name = "k_p"
upper = "x_p"
lower = "ground"
stiffness_n_per_m = 2.0e4
damping_n_s_per_m = 10.0
"#,
        )
        .unwrap();
        let s = Specimen::from_structure(&model, &["x_p".to_string()]).unwrap();
        let by_hand = Specimen {
            dofs: vec!["x_p".into()],
            mass: vec![vec![5.0]],
            static_force: vec![-5.0 * 9.81],
            elements: vec![PlacedElement {
                name: "k_p".into(),
                element: Element::linear(2.0e4, 10.0).with_preload(5.0 * 9.81),
                dof_coefficients: vec![-1.0],
                input_coefficients: vec![],
            }],
            inputs: vec![],
            attachments: vec![vec![1.0]],
        };
        assert_eq!(s, by_hand);
        assert!(s.static_imbalance(&[0.0]).iter().all(|f| f.abs() < 1e-9));
        let e = Specimen::from_structure(&model, &["x_q".to_string()]).unwrap_err();
        assert!(e.0.contains("x_q"), "{e}");
    }

    /// The quarter car on a road post with a lift-off tyre: at rest with no actuator force,
    /// the road an input of the tyre only, the tyre's preload the car's weight.
    #[test]
    fn a_quarter_car_structure_stands_on_its_road() {
        let text = format!(
            "{}\n[[effect]]\neffect = \"lift_off\"\nelement = \"tyre\"\n",
            include_str!("../../diagnose/examples/quarter-car.toml").replace(
                "name = \"quarter car\"",
                "name = \"quarter car\"\ngravity_m_per_s2 = 9.81"
            )
        );
        let model = Model::from_toml(&text).unwrap();
        let s = Specimen::from_structure(&model, &["x_s".to_string()]).unwrap();
        s.validate().unwrap();
        assert_eq!(s.inputs, vec!["road".to_string()]);
        assert!(s.static_imbalance(&[0.0]).iter().all(|f| f.abs() < 1e-9));
        let tyre = &s.elements[1];
        assert_eq!(tyre.input_coefficients, vec![1.0]);
        assert!(tyre.element.lifts_off());
        assert!((tyre.element.preload_n - 170.0 * 9.81).abs() < 1e-9);
        // Far above the road the tyre carries nothing.
        assert_eq!(tyre.element.force(-1.0, 0.0, 0.0).unwrap(), 0.0);
    }
}
