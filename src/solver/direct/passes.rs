//! The Newton passes of a line's or a tree's solve ([`newton_passes`]): when they stop, and how
//! each pass is checked ([`converges_next`]). The system itself — a line's tridiagonal
//! elimination (`elimination`) or a tree's from the leaves to the root (`tree`) — comes in
//! through [`NewtonSystem`]. See the [parent module's docs](super).

use super::TOLERANCE;

/// A line's or a tree's linearised system at the current iterate, as [`newton_passes`] drives
/// it.
pub(crate) trait NewtonSystem {
    /// The largest residual at the iterate (a traversal of lengths).
    fn residual(&mut self) -> f64;
    /// Takes the warm start back out of the iterate (and the multipliers).
    fn take_back(&mut self);
    /// Eliminates the system at the iterate (the first half of a pass); with `measure`,
    /// returns the residual at the iterate measured on the way (otherwise anything).
    fn eliminate(&mut self, measure: bool) -> f64;
    /// Substitutes back and moves the particles (the second half of a pass).
    fn substitute(&mut self);
}

/// Newton passes over `system` until it is within [`TOLERANCE`], `budget` passes are done, or a
/// pass leaves more than `contraction` × the error before it. `predicted` is the error before
/// the warm start: a warm start that made things worse is taken back. `fused`: the error to
/// start from is measured in the first pass's elimination (see [`converges_next`]). Returns the
/// passes taken and whether it converged.
pub(crate) fn newton_passes(
    system: &mut impl NewtonSystem,
    budget: u32,
    contraction: f64,
    predicted: f64,
    fused: bool,
) -> (u32, bool) {
    let mut error = if fused {
        system.eliminate(true)
    } else {
        system.residual()
    };
    let mut eliminated = fused;
    if error > predicted {
        system.take_back();
        error = system.residual();
        // (An elimination before the take-back is stale.)
        eliminated = false;
    }
    let mut passes = 0;
    let mut before = f64::INFINITY;
    loop {
        if error <= TOLERANCE {
            return (passes, true);
        }
        if passes == budget || error > contraction * before {
            return (passes, false);
        }
        let earlier = std::mem::replace(&mut before, error);
        if !eliminated {
            system.eliminate(false);
        }
        system.substitute();
        passes += 1;
        // Check with the lengths alone where this pass likely converged, else in the next
        // pass's elimination (see [`converges_next`]).
        eliminated = !converges_next(error, earlier);
        error = if eliminated {
            system.eliminate(true)
        } else {
            system.residual()
        };
    }
}

/// Whether a Newton pass that started at error `error` likely ends below [`TOLERANCE`], the
/// pass before it having started at `earlier` (`∞` for the first pass): Newton squares its
/// error near a root, `e_next ≈ K·e²`, with `K ≈ error / earlier²` from the pass before; the
/// first pass is expected to converge. It decides how the pass is checked: a traversal of
/// lengths alone (cheap when it is the last), or the residual measured on the way through the
/// next pass's forward traversal (free when a pass follows, an elimination spent in vain when
/// it does not). Measured with callgrind on whole test programs (8 × 1; the same passes and
/// results, to the bit): a 100-link 1000:1 chain swinging 5 s −6.6 % instructions, the swinging
/// Y rope of `tests/direct.rs` (a tree) −3.6 %, a 50 × 50 cloth hanging by lines for 2 s
/// +0.04 % (its lines converge in a pass or none). Fusing every check after the first pass
/// instead (with the residual measured in every forward traversal): −1.7 %, +4.6 %, +11 %.
pub(crate) fn converges_next(error: f64, earlier: f64) -> bool {
    error * error * error <= TOLERANCE * earlier * earlier
}

#[cfg(test)]
mod tests {
    use super::{NewtonSystem, newton_passes};

    /// A scalar system `x² = 2` (error `|x² − 2|`), counting its traversals; its take-back
    /// restarts from 1.5; `diverge`: each pass steps the wrong way, twice as far.
    #[derive(Default)]
    struct Root {
        x: f64,
        step: f64,
        diverge: bool,
        residuals: u32,
        measured: u32,
        plain: u32,
        taken_back: u32,
    }

    impl NewtonSystem for Root {
        fn residual(&mut self) -> f64 {
            self.residuals += 1;
            (self.x * self.x - 2.0).abs()
        }
        fn take_back(&mut self) {
            self.taken_back += 1;
            self.x = 1.5;
        }
        fn eliminate(&mut self, measure: bool) -> f64 {
            match measure {
                true => self.measured += 1,
                false => self.plain += 1,
            }
            self.step = (self.x * self.x - 2.0) / (2.0 * self.x);
            (self.x * self.x - 2.0).abs()
        }
        fn substitute(&mut self) {
            self.x -= if self.diverge {
                -2.0 * self.step
            } else {
                self.step
            };
        }
    }

    /// Newton's passes converge on the root in 3 passes from 1.5: the first and second
    /// checked by residuals (Newton's error has not squared yet), the third on the way through an
    /// elimination that is then spent on the check alone (see `converges_next`) — 3 residuals
    /// (the start's included), 2 plain eliminations and 1 measured.
    #[test]
    fn passes_converge_checked_once_each() {
        let mut root = Root {
            x: 1.5,
            ..Root::default()
        };
        let (passes, converged) = newton_passes(&mut root, 32, f64::INFINITY, f64::INFINITY, false);
        assert!(converged);
        assert!((root.x - 2f64.sqrt()).abs() < 1e-9, "x = {}", root.x);
        let counts = (passes, root.residuals, root.plain, root.measured);
        assert_eq!(counts, (3, 3, 2, 1));
    }

    /// A fused start measures the first error in the first pass's elimination, which that pass
    /// then uses: no plain elimination before it.
    #[test]
    fn a_fused_start_eliminates_once_for_the_first_pass() {
        let mut root = Root {
            x: 1.5,
            ..Root::default()
        };
        let (passes, converged) = newton_passes(&mut root, 32, f64::INFINITY, f64::INFINITY, true);
        assert!(converged);
        assert_eq!(
            (passes, root.residuals, root.plain, root.measured),
            (3, 2, 1, 2)
        );
    }

    /// A warm start that made the error worse than predicted is taken back, and the error is
    /// measured again; the passes then run as from the start without it (3 from 1.5) — not from
    /// the fused elimination made before the take-back, which is stale.
    #[test]
    fn a_worse_warm_start_is_taken_back() {
        let mut root = Root {
            x: 3.0,
            ..Root::default()
        };
        let (passes, converged) = newton_passes(&mut root, 32, f64::INFINITY, 1.0, true);
        assert!(converged);
        assert_eq!((root.taken_back, passes), (1, 3));
        assert!((root.x - 2f64.sqrt()).abs() < 1e-9, "x = {}", root.x);
    }

    /// A pass that leaves more than `contraction` × the error before it stops the passes,
    /// unconverged: a system stepping the wrong way stops after its first pass.
    #[test]
    fn a_pass_that_does_not_contract_stops_the_passes() {
        let mut root = Root {
            x: 1.5,
            diverge: true,
            ..Root::default()
        };
        let result = newton_passes(&mut root, 32, 0.5, f64::INFINITY, false);
        assert_eq!(result, (1, false));
    }

    /// Out of budget: unconverged after exactly `budget` passes.
    #[test]
    fn a_budget_stops_the_passes() {
        let mut root = Root {
            x: 100.0,
            ..Root::default()
        };
        let result = newton_passes(&mut root, 2, f64::INFINITY, f64::INFINITY, false);
        assert_eq!(result, (2, false));
    }
}
