//! The conjugate gradient's line search: it brackets the minimum (golden-ratio expansion, or
//! shrinking when the first trial step already climbs) and refines it with Brent's method
//! (parabolic interpolation with golden-section safeguards, MATLAB `srchbre`); it never
//! returns a step that raises the loss.

/// Golden ratio, for bracket expansion.
const GOLD: f64 = 1.618_033_988_749_895;
/// 1 - 1/golden ratio, for golden-section steps.
const CGOLD: f64 = 0.381_966_011_250_105;

/// The function searched, counting its evaluations; a non-finite value counts as infinite.
struct Counted<F> {
    phi: F,
    evals: usize,
}

impl<F: FnMut(f64) -> f64> Counted<F> {
    fn eval(&mut self, x: f64) -> f64 {
        self.evals += 1;
        let f = (self.phi)(x);
        if f.is_finite() {
            f
        } else {
            f64::INFINITY
        }
    }
}

/// Minimises `phi(alpha)` for `alpha >= 0` given `phi(0) = f0` and a first trial step
/// `alpha0 > 0`: bracket, then Brent. Returns `(alpha, phi(alpha))` with
/// `phi(alpha) <= f0` (`alpha = 0` when no lower point was found).
pub fn line_search(
    phi: impl FnMut(f64) -> f64,
    f0: f64,
    alpha0: f64,
    tol: f64,
    max_evals: usize,
) -> (f64, f64) {
    let mut phi = Counted { phi, evals: 0 };
    let abc = match bracket(&mut phi, f0, alpha0, max_evals) {
        Ok(abc) => abc,
        Err(answer) => return answer,
    };
    let (x, fx) = brent(&mut phi, abc, tol, max_evals);
    if fx < f0 {
        (x, fx)
    } else {
        (0.0, f0)
    }
}

/// Brackets the minimum: `[a, b, c, f(b)]` with 0 <= a < b < c, f(b) < f(a) and
/// f(b) <= f(c); or the search's answer when the evaluations ran out first (the first trial
/// climbs: `(0, f0)`; it descends: the last point of the expansion).
fn bracket<F: FnMut(f64) -> f64>(
    phi: &mut Counted<F>,
    f0: f64,
    alpha0: f64,
    max_evals: usize,
) -> Result<[f64; 4], (f64, f64)> {
    let mut a = 0.0;
    let mut b = alpha0;
    let mut fb = phi.eval(alpha0);
    let mut c;
    if fb >= f0 {
        // The first trial climbs: shrink towards 0 until a point below f(0).
        c = b;
        loop {
            if phi.evals >= max_evals || c < 1e-20 * alpha0.max(f64::MIN_POSITIVE) {
                return Err((0.0, f0));
            }
            b = 0.1 * c;
            fb = phi.eval(b);
            if fb < f0 {
                break;
            }
            c = b;
        }
    } else {
        // The first trial descends: expand by the golden ratio until the loss rises.
        c = b + GOLD * (b - a);
        let mut fc = phi.eval(c);
        while fc < fb {
            if phi.evals >= max_evals {
                return Err((c, fc));
            }
            a = b;
            b = c;
            fb = fc;
            c = b + GOLD * (b - a);
            fc = phi.eval(c);
        }
    }
    Ok([a, b, c, fb])
}

/// Brent's method on `[a, c]` from `x = b`: the lowest point found, `(x, f(x))`.
fn brent<F: FnMut(f64) -> f64>(
    phi: &mut Counted<F>,
    [a, b, c, fb]: [f64; 4],
    tol: f64,
    max_evals: usize,
) -> (f64, f64) {
    let (mut lo, mut hi) = (a.min(c), a.max(c));
    let (mut x, mut w, mut v) = (b, b, b);
    let (mut fx, mut fw, mut fv) = (fb, fb, fb);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    while phi.evals < max_evals {
        let xm = 0.5 * (lo + hi);
        let tol1 = tol * x.abs() + 1e-30;
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (hi - lo) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            if !(p.abs() >= (0.5 * q * etemp).abs() || p <= q * (lo - x) || p >= q * (hi - x)) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - lo < tol2 || hi - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { lo - x } else { hi - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = phi.eval(u);
        if fu <= fx {
            if u >= x {
                lo = x;
            } else {
                hi = x;
            }
            v = w;
            fv = fw;
            w = x;
            fw = fx;
            x = u;
            fx = fu;
        } else {
            if u < x {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == x {
                v = w;
                fv = fw;
                w = u;
                fw = fu;
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    (x, fx)
}
