//! Symmetric 3 × 3 matrices, six entries: what the curvature pass's elimination multiplies and
//! inverts (half the arithmetic of a general 3 × 3 matrix).

use glam::{DMat3, DVec3};
use std::ops::{Add, Mul};

/// A symmetric 3 × 3 matrix (upper triangle, row by row).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Sym3 {
    xx: f64,
    xy: f64,
    xz: f64,
    yy: f64,
    yz: f64,
    zz: f64,
}

impl Sym3 {
    /// `s I`.
    #[inline(always)]
    pub(crate) fn diagonal(s: f64) -> Self {
        Self {
            xx: s,
            yy: s,
            zz: s,
            ..Self::default()
        }
    }

    /// `s a aᵀ`.
    #[inline(always)]
    pub(crate) fn outer(a: DVec3, s: f64) -> Self {
        let sa = a * s;
        Self {
            xx: sa.x * a.x,
            xy: sa.x * a.y,
            xz: sa.x * a.z,
            yy: sa.y * a.y,
            yz: sa.y * a.z,
            zz: sa.z * a.z,
        }
    }

    /// `a bᵀ + b aᵀ`.
    #[inline(always)]
    pub(crate) fn symmetric_outer(a: DVec3, b: DVec3) -> Self {
        Self {
            xx: 2.0 * a.x * b.x,
            xy: a.x * b.y + b.x * a.y,
            xz: a.x * b.z + b.x * a.z,
            yy: 2.0 * a.y * b.y,
            yz: a.y * b.z + b.y * a.z,
            zz: 2.0 * a.z * b.z,
        }
    }

    /// The product with another symmetric matrix (not symmetric in general).
    #[inline(always)]
    pub(crate) fn times(self, other: Sym3) -> DMat3 {
        let (a, b) = (self.dense(), other.dense());
        a * b
    }

    /// `(A + Aᵀ)/2` of a general matrix.
    #[inline(always)]
    pub(crate) fn symmetric_part(m: &DMat3) -> Self {
        let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis); // columns
        Self {
            xx: x.x,
            xy: 0.5 * (y.x + x.y),
            xz: 0.5 * (z.x + x.z),
            yy: y.y,
            yz: 0.5 * (z.y + y.z),
            zz: z.z,
        }
    }

    /// As a general matrix.
    #[inline(always)]
    fn dense(self) -> DMat3 {
        DMat3::from_cols(
            DVec3::new(self.xx, self.xy, self.xz),
            DVec3::new(self.xy, self.yy, self.yz),
            DVec3::new(self.xz, self.yz, self.zz),
        )
    }

    /// The inverse by cofactors (not finite where the matrix is singular).
    #[inline(always)]
    pub(crate) fn inverse(self) -> Self {
        let (adjugate, det) = self.adjugate();
        adjugate * (1.0 / det)
    }

    /// The adjugate (the cofactors; `adj(A) = det(A) A⁻¹`) and the determinant.
    #[inline(always)]
    pub(crate) fn adjugate(self) -> (Self, f64) {
        let Self {
            xx,
            xy,
            xz,
            yy,
            yz,
            zz,
        } = self;
        let (cxx, cxy, cxz) = (yy * zz - yz * yz, xz * yz - xy * zz, xy * yz - xz * yy);
        let adjugate = Self {
            xx: cxx,
            xy: cxy,
            xz: cxz,
            yy: xx * zz - xz * xz,
            yz: xy * xz - xx * yz,
            zz: xx * yy - xy * xy,
        };
        (adjugate, xx * cxx + xy * cxy + xz * cxz)
    }
}

impl Add for Sym3 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            xx: self.xx + o.xx,
            xy: self.xy + o.xy,
            xz: self.xz + o.xz,
            yy: self.yy + o.yy,
            yz: self.yz + o.yz,
            zz: self.zz + o.zz,
        }
    }
}

impl Mul<f64> for Sym3 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: f64) -> Self {
        Self {
            xx: self.xx * s,
            xy: self.xy * s,
            xz: self.xz * s,
            yy: self.yy * s,
            yz: self.yz * s,
            zz: self.zz * s,
        }
    }
}

impl Mul<DVec3> for Sym3 {
    type Output = DVec3;
    #[inline(always)]
    fn mul(self, v: DVec3) -> DVec3 {
        DVec3::new(
            self.xx * v.x + self.xy * v.y + self.xz * v.z,
            self.xy * v.x + self.yy * v.y + self.yz * v.z,
            self.xz * v.x + self.yz * v.y + self.zz * v.z,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::Sym3;
    use glam::{DMat3, DVec3};

    fn dense(s: Sym3) -> DMat3 {
        DMat3::from_cols(s * DVec3::X, s * DVec3::Y, s * DVec3::Z)
    }

    #[test]
    fn products_and_inverse_match_glam() {
        let (a, b) = (DVec3::new(0.3, -1.2, 0.7), DVec3::new(2.0, 0.1, -0.4));
        let s = Sym3::diagonal(2.5) + Sym3::outer(a, 0.8) + Sym3::symmetric_outer(a * 0.3, b);
        let want = DMat3::from_diagonal(DVec3::splat(2.5))
            + DMat3::from_cols(a * a.x, a * a.y, a * a.z) * 0.8
            + (DMat3::from_cols(a * b.x, a * b.y, a * b.z)
                + DMat3::from_cols(b * a.x, b * a.y, b * a.z))
                * 0.3;
        assert!(dense(s).abs_diff_eq(want, 1e-12));
        assert!(dense(s.inverse()).abs_diff_eq(want.inverse(), 1e-12));
        assert!(dense(s * 2.0).abs_diff_eq(want * 2.0, 1e-12));
        let other = Sym3::diagonal(0.5) + Sym3::outer(b, 1.5);
        let product = want * dense(other);
        assert!(s.times(other).abs_diff_eq(product, 1e-12));
        let symmetric = (product + product.transpose()) * 0.5;
        assert!(dense(Sym3::symmetric_part(&product)).abs_diff_eq(symmetric, 1e-12));
    }
}
