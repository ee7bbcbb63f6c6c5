//! The state-variable filter of the baseline's regression: `F u`, `s F u` and `s^2 F u`
//! without differencing, exactly discretised for an input linear between samples.

use super::BaselineError;
use nalgebra::{Matrix2, Matrix4, Vector2};

/// The state-variable filter `F(s) = lambda^2 / (s + lambda)^2`, exactly discretised for an
/// input linear between samples.
///
/// State `x = (F u, s F u)`; `x' = A x + B u`, `A = [[0, 1], [-lambda^2, -2 lambda]]`,
/// `B = (0, lambda^2)`. Over a step h with `u` linear from `u0` to `u1`:
/// `x1 = Phi x0 + G0 u0 + G1 (u1 - u0) / h`, from `exp` of the augmented matrix
/// `[[A, B, 0], [0, 0, 1], [0, 0, 0]] h`.
#[derive(Debug, Clone, PartialEq)]
pub struct StateVariableFilter {
    lambda_rad_s: f64,
    dt_s: f64,
    phi: Matrix2<f64>,
    g0: Vector2<f64>,
    g1: Vector2<f64>,
    x: Vector2<f64>,
    u_prev: f64,
}

/// The three outputs of the filter at one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SvfOutput {
    /// `F u`.
    pub f: f64,
    /// `s F u` [per s].
    pub sf: f64,
    /// `s^2 F u` [per s^2].
    pub ssf: f64,
}

impl StateVariableFilter {
    /// The filter of bandwidth `lambda_rad_s` for samples `dt_s` apart, at rest on 0.
    pub fn new(lambda_rad_s: f64, dt_s: f64) -> Result<Self, BaselineError> {
        if !(lambda_rad_s.is_finite() && lambda_rad_s > 0.0) {
            return Err(BaselineError::InvalidArgument {
                what: "filter_rad_s",
                value: lambda_rad_s,
            });
        }
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(BaselineError::InvalidArgument {
                what: "dt_s",
                value: dt_s,
            });
        }
        let l = lambda_rad_s;
        #[rustfmt::skip]
        let m = Matrix4::new(
            0.0, 1.0, 0.0, 0.0,
            -l * l, -2.0 * l, l * l, 0.0,
            0.0, 0.0, 0.0, 1.0,
            0.0, 0.0, 0.0, 0.0,
        ) * dt_s;
        let e = m.exp();
        Ok(Self {
            lambda_rad_s,
            dt_s,
            phi: Matrix2::new(e[(0, 0)], e[(0, 1)], e[(1, 0)], e[(1, 1)]),
            g0: Vector2::new(e[(0, 2)], e[(1, 2)]),
            g1: Vector2::new(e[(0, 3)], e[(1, 3)]),
            x: Vector2::zeros(),
            u_prev: 0.0,
        })
    }

    /// Puts the filter at rest on a constant input `u0` (as if `u0` had always been applied),
    /// and returns the outputs there.
    pub fn reset(&mut self, u0: f64) -> SvfOutput {
        self.x = Vector2::new(u0, 0.0);
        self.u_prev = u0;
        self.output(u0)
    }

    /// Advances one sample period to the input `u` and returns the outputs there.
    pub fn step(&mut self, u: f64) -> SvfOutput {
        let slope = (u - self.u_prev) / self.dt_s;
        self.x = self.phi * self.x + self.g0 * self.u_prev + self.g1 * slope;
        self.u_prev = u;
        self.output(u)
    }

    fn output(&self, u: f64) -> SvfOutput {
        let l = self.lambda_rad_s;
        SvfOutput {
            f: self.x.x,
            sf: self.x.y,
            ssf: l * l * (u - self.x.x) - 2.0 * l * self.x.y,
        }
    }

    /// Transition matrix `exp(A dt)`, row major.
    pub fn transition(&self) -> [f64; 4] {
        [
            self.phi[(0, 0)],
            self.phi[(0, 1)],
            self.phi[(1, 0)],
            self.phi[(1, 1)],
        ]
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const DT: f64 = 0.1;

    /// The discretisation against the closed form of `exp(A h)` for the double pole,
    /// `e^{-l h} [[1 + l h, h], [-l^2 h, 1 - l h]]`.
    #[test]
    fn transition_matches_the_closed_form() {
        let (l, h) = (0.3, 0.1);
        let f = StateVariableFilter::new(l, h).unwrap();
        let e = (-l * h).exp();
        let want = [e * (1.0 + l * h), e * h, -e * l * l * h, e * (1.0 - l * h)];
        for (x, y) in f.transition().iter().zip(want) {
            assert!((x - y).abs() < 1e-15, "{:?} {want:?}", f.transition());
        }
    }

    /// A ramp is linear between samples, so the filter is exact on it: after the transient
    /// `F t = t - 2 / lambda`, `s F t = 1`, `s^2 F t = 0`.
    #[test]
    fn ramp_is_filtered_exactly() {
        let l = 0.3;
        let mut f = StateVariableFilter::new(l, DT).unwrap();
        let mut out = f.reset(0.0);
        for k in 1..=2000 {
            out = f.step(k as f64 * DT);
        }
        let t = 2000.0 * DT;
        assert!((out.f - (t - 2.0 / l)).abs() < 1e-10, "{out:?}");
        assert!((out.sf - 1.0).abs() < 1e-12, "{out:?}");
        assert!(out.ssf.abs() < 1e-12, "{out:?}");
    }

    /// A sine in steady state: the outputs have the gains and phases of `F(jw)`, `jw F(jw)`,
    /// `-w^2 F(jw)` (linear interpolation of a sine at w dt = 0.02: error < 1e-4).
    #[test]
    fn sine_response_matches_the_transfer_function() {
        let (l, w) = (0.3, 0.2);
        let mut f = StateVariableFilter::new(l, DT).unwrap();
        let n = 6000;
        let mut last = f.reset(0.0);
        for k in 1..=n {
            last = f.step((w * k as f64 * DT).sin());
        }
        let t = n as f64 * DT;
        // F(jw) = l^2 / (l + jw)^2: magnitude l^2 / (l^2 + w^2), phase -2 atan(w / l).
        let mag = l * l / (l * l + w * w);
        let ph = -2.0 * (w / l).atan();
        let want_f = mag * (w * t + ph).sin();
        let want_sf = w * mag * (w * t + ph + PI / 2.0).sin();
        let want_ssf = -w * w * mag * (w * t + ph).sin();
        assert!((last.f - want_f).abs() < 1e-4 * mag, "{} {want_f}", last.f);
        assert!((last.sf - want_sf).abs() < 1e-4 * w * mag);
        assert!((last.ssf - want_ssf).abs() < 1e-4 * w * w * mag);
    }
}
