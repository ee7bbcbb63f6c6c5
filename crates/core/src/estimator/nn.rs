//! The paper's network: a feedforward perceptron `[n_in, 10, 10, 1]`, tanh / tanh / linear,
//! with inputs and output scaled to [-1, 1] (paper eq. 14: `newff(minmax(p), [10, 10, 1],
//! {tansig, tansig, purelin})`).
//!
//! ## Model
//!
//! On a scaled input `x` (n_in) the network computes
//!
//! ```text
//! h1 = tanh(W1 x + b1)          W1: 10 x n_in, b1: 10
//! h2 = tanh(W2 h1 + b2)         W2: 10 x 10,   b2: 10
//! y  = w3 . h2 + b3             w3: 10,        b3: scalar
//! ```
//!
//! `P = 10 n_in + 131` parameters. Min-max scaling maps each raw input and the target from
//! `[min, max]` to `[-1, 1]` (MATLAB `mapminmax`): `x = 2 (p - min) / (max - min) - 1`, and
//! the output back by the inverse map. Units are those of the raw features and target (the
//! target is m/s or t; see [`crate::estimator::features`]).
//!
//! ## Parameter vector
//!
//! Trainers see the weights as one flat vector `theta` in this order: `W1` row by row (hidden
//! unit j's n_in weights), `b1`, `W2` row by row, `b2`, `w3`, `b3`.
//!
//! ## Derivatives
//!
//! Backpropagation of the scalar output gives the Jacobian row `dy/dtheta` used by
//! Levenberg-Marquardt and, summed with the residuals, the gradient used by conjugate
//! gradient:
//!
//! ```text
//! dy/db3 = 1,  dy/dw3 = h2
//! g2 = w3 .* (1 - h2^2)          dy/dW2 = g2 h1^T,  dy/db2 = g2
//! g1 = (W2^T g2) .* (1 - h1^2)   dy/dW1 = g1 x^T,   dy/db1 = g1
//! ```
//!
//! ## Allocation
//!
//! [`Mlp::predict`] and the derivative functions work in a preallocated [`Scratch`] and
//! allocate nothing.

use nalgebra::{DMatrix, DVector};

/// Units in each hidden layer (paper eq. 14).
pub const HIDDEN: usize = 10;

/// Number of parameters of a network with `n_in` inputs: `10 n_in + 131`.
pub const fn n_params(n_in: usize) -> usize {
    HIDDEN * n_in + HIDDEN + HIDDEN * HIDDEN + HIDDEN + HIDDEN + 1
}

/// A network whose shapes or values are unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NnError {
    /// A network needs at least one input.
    #[error("a network needs at least one input")]
    NoInput,
    /// A vector or matrix has the wrong length.
    #[error("{what}: expected {expected} values, got {got}")]
    Shape {
        /// What was checked.
        what: String,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what}: value {index} is not finite")]
    NotFinite {
        /// What was checked.
        what: String,
        /// Index of the offending value.
        index: usize,
    },
    /// A scaling range is empty or reversed (max <= min).
    #[error("{what}: range {index} is empty (min {min} >= max {max})")]
    EmptyRange {
        /// What was checked.
        what: String,
        /// Index of the offending range.
        index: usize,
        /// Its minimum.
        min: f64,
        /// Its maximum.
        max: f64,
    },
}

fn check_finite(what: &str, v: &[f64]) -> Result<(), NnError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(NnError::NotFinite {
            what: what.to_string(),
            index,
        }),
        None => Ok(()),
    }
}

fn check_len(what: &str, v: &[f64], expected: usize) -> Result<(), NnError> {
    if v.len() == expected {
        Ok(())
    } else {
        Err(NnError::Shape {
            what: what.to_string(),
            expected,
            got: v.len(),
        })
    }
}

/// Min-max scaling of the inputs and of the output to [-1, 1] (MATLAB `mapminmax`).
#[derive(Debug, Clone, PartialEq)]
pub struct Scaling {
    /// Smallest value of each raw input (training data).
    pub x_min: Vec<f64>,
    /// Largest value of each raw input.
    pub x_max: Vec<f64>,
    /// Raw target mapped to -1.
    pub y_min: f64,
    /// Raw target mapped to +1.
    pub y_max: f64,
}

impl Scaling {
    /// Checks lengths, finiteness and non-empty ranges.
    pub fn new(x_min: Vec<f64>, x_max: Vec<f64>, y_min: f64, y_max: f64) -> Result<Self, NnError> {
        if x_min.is_empty() {
            return Err(NnError::NoInput);
        }
        check_len("input scaling max", &x_max, x_min.len())?;
        check_finite("input scaling min", &x_min)?;
        check_finite("input scaling max", &x_max)?;
        check_finite("output scaling", &[y_min, y_max])?;
        for (index, (&min, &max)) in x_min.iter().zip(&x_max).enumerate() {
            if max <= min {
                return Err(NnError::EmptyRange {
                    what: "input scaling".into(),
                    index,
                    min,
                    max,
                });
            }
        }
        if y_max <= y_min {
            return Err(NnError::EmptyRange {
                what: "output scaling".into(),
                index: 0,
                min: y_min,
                max: y_max,
            });
        }
        Ok(Self {
            x_min,
            x_max,
            y_min,
            y_max,
        })
    }

    /// The scaling that maps the column-wise minimum and maximum of `rows` to [-1, 1].
    pub fn from_data<'a>(
        rows: impl IntoIterator<Item = &'a [f64]>,
        y_min: f64,
        y_max: f64,
    ) -> Result<Self, NnError> {
        let mut x_min: Vec<f64> = Vec::new();
        let mut x_max: Vec<f64> = Vec::new();
        for row in rows {
            if x_min.is_empty() {
                x_min = row.to_vec();
                x_max = row.to_vec();
                continue;
            }
            check_len("data row", row, x_min.len())?;
            for (i, &v) in row.iter().enumerate() {
                x_min[i] = x_min[i].min(v);
                x_max[i] = x_max[i].max(v);
            }
        }
        Self::new(x_min, x_max, y_min, y_max)
    }

    /// Number of inputs.
    pub fn n_in(&self) -> usize {
        self.x_min.len()
    }

    /// Raw input `i` to [-1, 1].
    pub fn scale_x(&self, i: usize, v: f64) -> f64 {
        2.0 * (v - self.x_min[i]) / (self.x_max[i] - self.x_min[i]) - 1.0
    }

    /// Raw target to [-1, 1].
    pub fn scale_y(&self, y: f64) -> f64 {
        2.0 * (y - self.y_min) / (self.y_max - self.y_min) - 1.0
    }

    /// [-1, 1] back to the raw target.
    pub fn unscale_y(&self, s: f64) -> f64 {
        self.y_min + 0.5 * (s + 1.0) * (self.y_max - self.y_min)
    }
}

/// The weights of one `[n_in, 10, 10, 1]` network (acting on scaled inputs and output).
#[derive(Debug, Clone, PartialEq)]
pub struct Mlp {
    /// First layer weights, 10 x n_in.
    pub w1: DMatrix<f64>,
    /// First layer biases.
    pub b1: DVector<f64>,
    /// Second layer weights, 10 x 10.
    pub w2: DMatrix<f64>,
    /// Second layer biases.
    pub b2: DVector<f64>,
    /// Output weights.
    pub w3: DVector<f64>,
    /// Output bias.
    pub b3: f64,
}

/// Preallocated buffers for one network's evaluations (one per thread).
#[derive(Debug, Clone)]
pub struct Scratch {
    /// Scaled input.
    x: DVector<f64>,
    /// First hidden layer output.
    h1: DVector<f64>,
    /// Second hidden layer output.
    h2: DVector<f64>,
    /// Backpropagated sensitivity at the first layer.
    g1: DVector<f64>,
    /// Backpropagated sensitivity at the second layer.
    g2: DVector<f64>,
}

impl Scratch {
    /// Buffers for networks with `n_in` inputs.
    pub fn new(n_in: usize) -> Self {
        Self {
            x: DVector::zeros(n_in),
            h1: DVector::zeros(HIDDEN),
            h2: DVector::zeros(HIDDEN),
            g1: DVector::zeros(HIDDEN),
            g2: DVector::zeros(HIDDEN),
        }
    }

    /// Number of inputs these buffers serve.
    pub fn n_in(&self) -> usize {
        self.x.len()
    }
}

impl Mlp {
    /// A network with every weight zero.
    pub fn zeros(n_in: usize) -> Self {
        Self {
            w1: DMatrix::zeros(HIDDEN, n_in),
            b1: DVector::zeros(HIDDEN),
            w2: DMatrix::zeros(HIDDEN, HIDDEN),
            b2: DVector::zeros(HIDDEN),
            w3: DVector::zeros(HIDDEN),
            b3: 0.0,
        }
    }

    /// A network from a flat parameter vector (see the module documentation for the order).
    pub fn from_params(n_in: usize, theta: &[f64]) -> Result<Self, NnError> {
        if n_in == 0 {
            return Err(NnError::NoInput);
        }
        check_len("parameter vector", theta, n_params(n_in))?;
        check_finite("parameter vector", theta)?;
        let mut m = Self::zeros(n_in);
        m.set_params(theta);
        Ok(m)
    }

    /// Number of inputs.
    pub fn n_in(&self) -> usize {
        self.w1.ncols()
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        n_params(self.n_in())
    }

    /// Writes the parameters into `theta` (length [`Mlp::n_params`]).
    pub fn params_into(&self, theta: &mut [f64]) {
        let mut k = 0;
        let mut put = |v: f64| {
            if let Some(slot) = theta.get_mut(k) {
                *slot = v;
            }
            k += 1;
        };
        for j in 0..HIDDEN {
            for i in 0..self.n_in() {
                put(self.w1[(j, i)]);
            }
        }
        self.b1.iter().for_each(|&v| put(v));
        for j in 0..HIDDEN {
            for i in 0..HIDDEN {
                put(self.w2[(j, i)]);
            }
        }
        self.b2.iter().for_each(|&v| put(v));
        self.w3.iter().for_each(|&v| put(v));
        put(self.b3);
    }

    /// The parameters as a new vector.
    pub fn params(&self) -> Vec<f64> {
        let mut theta = vec![0.0; self.n_params()];
        self.params_into(&mut theta);
        theta
    }

    /// Sets the parameters from `theta` (length [`Mlp::n_params`]; missing values read as 0).
    pub fn set_params(&mut self, theta: &[f64]) {
        let n_in = self.n_in();
        let mut it = theta.iter().copied();
        let mut get = || it.next().unwrap_or(0.0);
        for j in 0..HIDDEN {
            for i in 0..n_in {
                self.w1[(j, i)] = get();
            }
        }
        for j in 0..HIDDEN {
            self.b1[j] = get();
        }
        for j in 0..HIDDEN {
            for i in 0..HIDDEN {
                self.w2[(j, i)] = get();
            }
        }
        for j in 0..HIDDEN {
            self.b2[j] = get();
        }
        for j in 0..HIDDEN {
            self.w3[j] = get();
        }
        self.b3 = get();
    }

    /// Output on a scaled input held in `s` (after [`Mlp::load_input`]); fills the hidden
    /// layers of `s`.
    fn forward_loaded(&self, s: &mut Scratch) -> f64 {
        s.h1.copy_from(&self.b1);
        s.h1.gemv(1.0, &self.w1, &s.x, 1.0);
        s.h1.apply(|v| *v = v.tanh());
        s.h2.copy_from(&self.b2);
        s.h2.gemv(1.0, &self.w2, &s.h1, 1.0);
        s.h2.apply(|v| *v = v.tanh());
        self.w3.dot(&s.h2) + self.b3
    }

    /// Copies the scaled input `x` into the scratch.
    fn load_input(s: &mut Scratch, x: &[f64]) {
        for (slot, &v) in s.x.iter_mut().zip(x) {
            *slot = v;
        }
    }

    /// Output for a scaled input `x` (length n_in), in [-1, 1] units. No allocation.
    pub fn forward(&self, x: &[f64], s: &mut Scratch) -> f64 {
        Self::load_input(s, x);
        self.forward_loaded(s)
    }

    /// Raw prediction: scales the raw input `p` with `scaling`, runs the network and maps
    /// the output back to the target's units. No allocation.
    pub fn predict(&self, scaling: &Scaling, p: &[f64], s: &mut Scratch) -> f64 {
        for (i, (slot, &v)) in s.x.iter_mut().zip(p).enumerate() {
            *slot = scaling.scale_x(i, v);
        }
        let y = self.forward_loaded(s);
        scaling.unscale_y(y)
    }

    /// Output for the scaled input `x` and its gradient with respect to the parameters,
    /// written into `row` (length [`Mlp::n_params`], the order of the parameter vector).
    /// No allocation.
    pub fn jacobian_row(&self, x: &[f64], s: &mut Scratch, row: &mut [f64]) -> f64 {
        Self::load_input(s, x);
        let y = self.forward_loaded(s);
        let n_in = self.n_in();
        // Output layer sensitivities.
        for j in 0..HIDDEN {
            s.g2[j] = self.w3[j] * (1.0 - s.h2[j] * s.h2[j]);
        }
        // g1 = (W2^T g2) .* (1 - h1^2)
        s.g1.gemv_tr(1.0, &self.w2, &s.g2, 0.0);
        for j in 0..HIDDEN {
            s.g1[j] *= 1.0 - s.h1[j] * s.h1[j];
        }
        let o_b1 = HIDDEN * n_in;
        let o_w2 = o_b1 + HIDDEN;
        let o_b2 = o_w2 + HIDDEN * HIDDEN;
        let o_w3 = o_b2 + HIDDEN;
        let o_b3 = o_w3 + HIDDEN;
        if row.len() < o_b3 + 1 {
            return y;
        }
        for j in 0..HIDDEN {
            let g = s.g1[j];
            let base = j * n_in;
            for i in 0..n_in {
                row[base + i] = g * s.x[i];
            }
            row[o_b1 + j] = g;
            let g = s.g2[j];
            let base = o_w2 + j * HIDDEN;
            for i in 0..HIDDEN {
                row[base + i] = g * s.h1[i];
            }
            row[o_b2 + j] = g;
            row[o_w3 + j] = s.h2[j];
        }
        row[o_b3] = 1.0;
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_net(n_in: usize, seed: u64) -> Mlp {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let theta: Vec<f64> = (0..n_params(n_in))
            .map(|_| rng.gen_range(-1.0..1.0))
            .collect();
        Mlp::from_params(n_in, &theta).unwrap()
    }

    #[test]
    fn parameter_count_matches_the_domain_formula() {
        // [n, 10, 10, 1] with biases: (10 n + 10) + (100 + 10) + (10 + 1) = 10 n + 131.
        for n in 1..10 {
            assert_eq!(n_params(n), 10 * n + 131);
        }
    }

    #[test]
    fn params_round_trip_and_order() {
        let net = random_net(3, 1);
        let theta = net.params();
        assert_eq!(Mlp::from_params(3, &theta).unwrap(), net);
        // Spot-check the documented order.
        assert_eq!(theta[0], net.w1[(0, 0)]);
        assert_eq!(theta[4], net.w1[(1, 1)]);
        assert_eq!(theta[30], net.b1[0]);
        assert_eq!(theta[40 + 12], net.w2[(1, 2)]);
        assert_eq!(theta[140], net.b2[0]);
        assert_eq!(theta[150 + 9], net.w3[9]);
        assert_eq!(theta[160], net.b3);
    }

    #[test]
    fn forward_matches_a_hand_computation() {
        let net = random_net(2, 2);
        let x = [0.3, -0.7];
        let mut h1 = [0.0; HIDDEN];
        for (j, h) in h1.iter_mut().enumerate() {
            *h = (net.w1[(j, 0)] * x[0] + net.w1[(j, 1)] * x[1] + net.b1[j]).tanh();
        }
        let mut y = net.b3;
        for j in 0..HIDDEN {
            let mut z = net.b2[j];
            for (i, h) in h1.iter().enumerate() {
                z += net.w2[(j, i)] * h;
            }
            y += net.w3[j] * z.tanh();
        }
        let mut s = Scratch::new(2);
        approx::assert_relative_eq!(net.forward(&x, &mut s), y, max_relative = 1e-14);
    }

    #[test]
    fn jacobian_row_matches_central_differences() {
        for (n_in, seed) in [(1, 3), (3, 4), (7, 5)] {
            let net = random_net(n_in, seed);
            let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
            let x: Vec<f64> = (0..n_in).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let mut s = Scratch::new(n_in);
            let mut row = vec![0.0; n_params(n_in)];
            let y = net.jacobian_row(&x, &mut s, &mut row);
            approx::assert_relative_eq!(y, net.forward(&x, &mut s), max_relative = 1e-15);
            let theta = net.params();
            let h = 1e-6;
            for k in 0..theta.len() {
                let mut tp = theta.clone();
                tp[k] += h;
                let mut tm = theta.clone();
                tm[k] -= h;
                let fp = Mlp::from_params(n_in, &tp).unwrap().forward(&x, &mut s);
                let fm = Mlp::from_params(n_in, &tm).unwrap().forward(&x, &mut s);
                let fd = (fp - fm) / (2.0 * h);
                assert!(
                    (row[k] - fd).abs() <= 1e-8 + 1e-6 * fd.abs(),
                    "n_in {n_in} param {k}: analytic {} vs finite difference {fd}",
                    row[k]
                );
            }
        }
    }

    #[test]
    fn scaling_maps_range_to_unit_interval_and_back() {
        let rows = [vec![1.0, -5.0], vec![3.0, 5.0], vec![2.0, 0.0]];
        let sc = Scaling::from_data(rows.iter().map(|r| r.as_slice()), 4.0, 10.0).unwrap();
        assert_eq!(sc.x_min, vec![1.0, -5.0]);
        assert_eq!(sc.x_max, vec![3.0, 5.0]);
        assert_eq!(sc.scale_x(0, 1.0), -1.0);
        assert_eq!(sc.scale_x(0, 3.0), 1.0);
        assert_eq!(sc.scale_x(1, 0.0), 0.0);
        assert_eq!(sc.scale_y(4.0), -1.0);
        assert_eq!(sc.scale_y(10.0), 1.0);
        approx::assert_relative_eq!(sc.unscale_y(sc.scale_y(6.3)), 6.3, max_relative = 1e-15);
    }

    #[test]
    fn predict_scales_then_unscales() {
        let net = random_net(2, 6);
        let sc = Scaling::new(vec![0.0, 10.0], vec![2.0, 20.0], 4000.0, 10000.0).unwrap();
        let mut s = Scratch::new(2);
        let raw = net.predict(&sc, &[1.5, 12.0], &mut s);
        let scaled = net.forward(&[0.5, -0.6], &mut s);
        approx::assert_relative_eq!(raw, 7000.0 + 3000.0 * scaled, max_relative = 1e-12);
    }

    #[test]
    fn bad_shapes_and_values_are_refused() {
        assert!(matches!(
            Mlp::from_params(2, &[0.0; 10]),
            Err(NnError::Shape { .. })
        ));
        let mut theta = vec![0.0; n_params(2)];
        theta[7] = f64::NAN;
        assert!(matches!(
            Mlp::from_params(2, &theta),
            Err(NnError::NotFinite { index: 7, .. })
        ));
        assert!(matches!(Mlp::from_params(0, &[]), Err(NnError::NoInput)));
        assert!(matches!(
            Scaling::new(vec![1.0], vec![1.0], 0.0, 1.0),
            Err(NnError::EmptyRange { .. })
        ));
        assert!(matches!(
            Scaling::new(vec![0.0], vec![1.0], 2.0, 1.0),
            Err(NnError::EmptyRange { .. })
        ));
    }
}
