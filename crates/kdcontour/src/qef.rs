//! The quadratic error function of the paper (section 4.1).
//!
//! `E1(x) = Σ (n_i · (x - p_i))²` in matrix form `xᵀAᵀAx - 2xᵀAᵀb + bᵀb`, plus the
//! per-dimension error `E2(x)_k = Σ (n_ik (x_k - p_ik))²`, which needs the three
//! extra vectors `diag(AᵀA)`, `diag(AᵀC)` and `diag(CᵀC)` (`C`'s rows are
//! `n_i ⊗ p_i`). QEFs add, so a box's QEF is the sum of its cells'.
//!
//! Positions are in grid units (one cell = 1), so errors are in squared cells.
//! Sums are kept in f64: at res 128 the `bᵀb` term reaches 10⁸ per cell while the
//! residuals that set the level of detail are 10⁻³, which f32 cannot tell apart.

use glam::{DVec3, Vec3};

/// Eigenvalues of `AᵀA` below this fraction of the largest are truncated by the
/// solver. For two planes meeting at dihedral angle θ the eigenvalue ratio is
/// tan²(θ/2); 0.02 keeps creases sharper than 16° and treats the spread of normals
/// across one cell of a curved surface (a sphere of radius 8 cells spreads them by
/// about 7°, ratio 0.004) as noise, so smooth surfaces get no spiky vertices.
pub(crate) const SVD_CUTOFF: f64 = 0.02;

/// Accumulated Hermite planes of a region.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Qef {
    /// Upper triangle of `AᵀA`: xx, xy, xz, yy, yz, zz.
    pub ata: [f64; 6],
    /// `Aᵀb`.
    pub atb: DVec3,
    /// `bᵀb`.
    pub btb: f64,
    /// Sum of the points (for the mass point).
    pub mass: DVec3,
    /// Number of planes.
    pub count: f64,
    /// `diag(AᵀC)`: Σ n_k² p_k.
    pub atc: DVec3,
    /// `diag(CᵀC)`: Σ n_k² p_k².
    pub ctc: DVec3,
}

impl Qef {
    /// The empty QEF (no planes).
    pub const ZERO: Qef = Qef {
        ata: [0.0; 6],
        atb: DVec3::ZERO,
        btb: 0.0,
        mass: DVec3::ZERO,
        count: 0.0,
        atc: DVec3::ZERO,
        ctc: DVec3::ZERO,
    };
}

impl std::ops::AddAssign<&Qef> for Qef {
    fn add_assign(&mut self, o: &Qef) {
        for i in 0..6 {
            self.ata[i] += o.ata[i];
        }
        self.atb += o.atb;
        self.btb += o.btb;
        self.mass += o.mass;
        self.count += o.count;
        self.atc += o.atc;
        self.ctc += o.ctc;
    }
}

impl std::ops::SubAssign<&Qef> for Qef {
    fn sub_assign(&mut self, o: &Qef) {
        for i in 0..6 {
            self.ata[i] -= o.ata[i];
        }
        self.atb -= o.atb;
        self.btb -= o.btb;
        self.mass -= o.mass;
        self.count -= o.count;
        self.atc -= o.atc;
        self.ctc -= o.ctc;
    }
}

impl Qef {
    /// Adds the plane through `p` with unit normal `n`.
    pub fn add_plane(&mut self, p: Vec3, n: Vec3) {
        let p = p.as_dvec3();
        let n = n.as_dvec3();
        self.ata[0] += n.x * n.x;
        self.ata[1] += n.x * n.y;
        self.ata[2] += n.x * n.z;
        self.ata[3] += n.y * n.y;
        self.ata[4] += n.y * n.z;
        self.ata[5] += n.z * n.z;
        let d = n.dot(p);
        self.atb += n * d;
        self.btb += d * d;
        self.mass += p;
        self.count += 1.0;
        let n2 = n * n;
        self.atc += n2 * p;
        self.ctc += n2 * p * p;
    }

    /// Mean of the points.
    pub fn mass_point(&self) -> DVec3 {
        if self.count > 0.0 {
            self.mass / self.count
        } else {
            DVec3::ZERO
        }
    }

    fn mul(&self, x: DVec3) -> DVec3 {
        let a = &self.ata;
        DVec3::new(
            a[0] * x.x + a[1] * x.y + a[2] * x.z,
            a[1] * x.x + a[3] * x.y + a[4] * x.z,
            a[2] * x.x + a[4] * x.y + a[5] * x.z,
        )
    }

    /// `E1(x)`, clamped at zero against rounding.
    pub fn error_at(&self, x: DVec3) -> f64 {
        (x.dot(self.mul(x)) - 2.0 * x.dot(self.atb) + self.btb).max(0.0)
    }

    /// `E2(x)`: the error per dimension.
    pub fn error_per_axis(&self, x: DVec3) -> DVec3 {
        let diag = DVec3::new(self.ata[0], self.ata[3], self.ata[5]);
        (x * x * diag - 2.0 * x * self.atc + self.ctc).max(DVec3::ZERO)
    }

    /// The minimiser of `E1` within the box `[lo, hi]` and `E1` there.
    ///
    /// The unconstrained minimiser comes from a truncated pseudo-inverse around the
    /// mass point (see `SVD_CUTOFF`). When it leaves the box (a crease that passes
    /// just outside the cell), clamping its coordinates would pull it off the
    /// surface. Instead the coordinates that leave are held on the box and the
    /// others re-solved, up to three rounds (an active-set method); the result is
    /// never worse than the clamped point.
    pub fn solve(&self, lo: Vec3, hi: Vec3) -> (Vec3, f64) {
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        let m = self.mass_point().clamp(lo, hi);
        let mut x = self.solve_fixed(m, [false; 3]);
        let outside = |x: DVec3| [0, 1, 2].map(|k| x[k] < lo[k] - 1e-9 || x[k] > hi[k] + 1e-9);
        let mut out = outside(x);
        if !out.contains(&true) {
            let x = x.clamp(lo, hi);
            return (x.as_vec3(), self.error_at(x));
        }
        let clamped = x.clamp(lo, hi);
        let mut fixed = [false; 3];
        for _round in 0..3 {
            for k in 0..3 {
                fixed[k] |= out[k];
            }
            x = self.solve_fixed(x.clamp(lo, hi), fixed);
            out = outside(x);
            if !out.contains(&true) {
                break;
            }
        }
        let x = x.clamp(lo, hi);
        let (e, ec) = (self.error_at(x), self.error_at(clamped));
        if e <= ec {
            (x.as_vec3(), e)
        } else {
            (clamped.as_vec3(), ec)
        }
    }

    /// Minimises `E1` over the coordinates not `fixed`, starting from `start` (whose
    /// fixed coordinates stay), by truncated pseudo-inverse of the free block.
    fn solve_fixed(&self, start: DVec3, fixed: [bool; 3]) -> DVec3 {
        // Gradient of E1 at start is 2 (AᵀA start - Aᵀb); restricted to free axes.
        let rhs = self.atb - self.mul(start);
        let a = &self.ata;
        let full = [[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]];
        let mut sub = [0f64; 6];
        let idx = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
        for (s, &(i, j)) in sub.iter_mut().zip(&idx) {
            *s = if fixed[i] || fixed[j] {
                0.0
            } else {
                full[i][j]
            };
        }
        let rhs = DVec3::new(
            if fixed[0] { 0.0 } else { rhs.x },
            if fixed[1] { 0.0 } else { rhs.y },
            if fixed[2] { 0.0 } else { rhs.z },
        );
        if fixed == [false; 3] {
            if let Some((val, v)) = dominant_eigen(sub) {
                // Both other eigenvalues are below the cutoff: the truncated
                // pseudo-inverse keeps this direction alone.
                return start + v * (v.dot(rhs) / val);
            }
        }
        let (vals, vecs) = sym_eigen_closed(sub);
        let max = vals.iter().cloned().fold(0.0f64, f64::max);
        let mut x = start;
        if max > 0.0 {
            for k in 0..3 {
                if vals[k] > SVD_CUTOFF * max {
                    let v = vecs[k];
                    x += v * (v.dot(rhs) / vals[k]);
                }
            }
        }
        x
    }

    /// A cheap estimate of the minimal `E1` (a ridge-regularised solve around the mass
    /// point, no eigen decomposition). The k-d split search calls this O(log n) times
    /// per node, where the exact solve would dominate the build.
    pub fn fast_min_error(&self) -> f64 {
        if self.count <= 0.0 {
            return 0.0;
        }
        self.error_at(self.fast_minimizer())
    }

    /// The minimiser used by [`Qef::fast_min_error`].
    pub fn fast_minimizer(&self) -> DVec3 {
        let m = self.mass_point();
        let rhs = self.atb - self.mul(m);
        let a = &self.ata;
        let lambda = SVD_CUTOFF * (a[0] + a[3] + a[5]) / 3.0 + 1e-12;
        let (xx, xy, xz, yy, yz, zz) = (
            a[0] + lambda,
            a[1],
            a[2],
            a[3] + lambda,
            a[4],
            a[5] + lambda,
        );
        let c00 = yy * zz - yz * yz;
        let c01 = xz * yz - xy * zz;
        let c02 = xy * yz - xz * yy;
        let det = xx * c00 + xy * c01 + xz * c02;
        if det.abs() < 1e-300 {
            return m;
        }
        let c11 = xx * zz - xz * xz;
        let c12 = xy * xz - xx * yz;
        let c22 = xx * yy - xy * xy;
        let y = DVec3::new(
            c00 * rhs.x + c01 * rhs.y + c02 * rhs.z,
            c01 * rhs.x + c11 * rhs.y + c12 * rhs.z,
            c02 * rhs.x + c12 * rhs.y + c22 * rhs.z,
        ) / det;
        m + y
    }
}

/// The largest eigenvalue and its unit eigenvector of a positive semi-definite
/// symmetric 3x3 matrix (upper triangle), when the other two eigenvalues are
/// certainly at most [`SVD_CUTOFF`] times it (a nearly flat patch: the common case
/// on smooth surfaces); `None` otherwise.
///
/// Power iteration by repeated squaring: the largest column of `A⁸` has its other
/// eigen-directions shrunk by the eigenvalue ratio to the 8th power (below 3e-14
/// when this succeeds), for a fixed 3 matrix squarings. The Rayleigh quotient
/// `λ` never exceeds the true largest eigenvalue, so `trace - λ` bounds the sum of
/// the other two from above and the test below can only err towards `None`, when
/// the caller falls back to [`sym_eigen_closed`]. Measured with callgrind on the
/// sphere, a solve through it takes about 400 instructions where the closed-form
/// decomposition alone took 665. Where [`surely_spread`] already says no, it
/// does not square.
fn dominant_eigen(a: [f64; 6]) -> Option<(f64, DVec3)> {
    if surely_spread(a) {
        return None;
    }
    dominant_eigen_by_squaring(a)
}

/// Whether [`dominant_eigen_by_squaring`] surely declines `a` (with a
/// non-negative trace), read off its Frobenius norm: it succeeds only with a
/// Rayleigh quotient, hence a largest eigenvalue, above `trace / (1 +
/// SVD_CUTOFF)`, and the largest eigenvalue is at most the Frobenius norm.
/// A margin of 1e-9 keeps rounding on the side of squaring. On curved or
/// creased patches (the terrain's, the other eigenvalues above a fiftieth) it
/// saves the three squarings: `pipeline::full` on terrain at 32, 3.76 to 3.67
/// ms, the same mesh.
fn surely_spread(a: [f64; 6]) -> bool {
    let trace = a[0] + a[3] + a[5];
    let frob2 =
        a[0] * a[0] + a[3] * a[3] + a[5] * a[5] + 2.0 * (a[1] * a[1] + a[2] * a[2] + a[4] * a[4]);
    let bar = trace / (1.0 + SVD_CUTOFF);
    frob2 < bar * bar * (1.0 - 1e-9)
}

/// [`dominant_eigen`] by three squarings, whatever the matrix.
fn dominant_eigen_by_squaring(a: [f64; 6]) -> Option<(f64, DVec3)> {
    let trace = a[0] + a[3] + a[5];
    if !(trace > 0.0 && trace.is_finite()) {
        return None;
    }
    let mut b = a.map(|x| x / trace);
    for _ in 0..3 {
        let [xx, xy, xz, yy, yz, zz] = b;
        let sq = [
            xx * xx + xy * xy + xz * xz,
            xx * xy + xy * yy + xz * yz,
            xx * xz + xy * yz + xz * zz,
            xy * xy + yy * yy + yz * yz,
            xy * xz + yy * yz + yz * zz,
            xz * xz + yz * yz + zz * zz,
        ];
        let t = sq[0] + sq[3] + sq[5];
        // Not `t <= 1e-200`: a NaN must decline too.
        if t.is_nan() || t <= 1e-200 {
            return None;
        }
        b = sq.map(|x| x / t);
    }
    let col = if b[0] >= b[3] && b[0] >= b[5] {
        DVec3::new(b[0], b[1], b[2])
    } else if b[3] >= b[5] {
        DVec3::new(b[1], b[3], b[4])
    } else {
        DVec3::new(b[2], b[4], b[5])
    };
    let v = col.normalize_or_zero();
    let av = DVec3::new(
        a[0] * v.x + a[1] * v.y + a[2] * v.z,
        a[1] * v.x + a[3] * v.y + a[4] * v.z,
        a[2] * v.x + a[4] * v.y + a[5] * v.z,
    );
    let val = v.dot(av);
    // The other two eigenvalues sum to trace - λ1 <= trace - val.
    (val > 0.0 && trace - val <= SVD_CUTOFF * val * (1.0 - 1e-6)).then_some((val, v))
}

/// Eigen decomposition of a symmetric 3x3 matrix (upper triangle xx, xy, xz, yy, yz,
/// zz) in closed form: eigenvalues from the trigonometric solution of the
/// characteristic cubic, eigenvectors from cross products of the rows of `A - λI`
/// and, for the second, a 2x2 problem in the plane orthogonal to the first, which
/// stays exact when eigenvalues repeat (D. Eberly, "A Robust Eigensolver for 3x3
/// Symmetric Matrices", Geometric Tools, 2014). Returns eigenvalues and unit
/// eigenvectors (an orthonormal basis). About three times cheaper than
/// [`sym_eigen`], which the tests hold it to.
pub fn sym_eigen_closed(a: [f64; 6]) -> ([f64; 3], [DVec3; 3]) {
    let max0 = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if max0 == 0.0 || !max0.is_finite() {
        return ([0.0; 3], [DVec3::X, DVec3::Y, DVec3::Z]);
    }
    // Scale to [-1, 1] against overflow and underflow.
    let [a00, a01, a02, a11, a12, a22] = a.map(|v| v / max0);
    let norm = a01 * a01 + a02 * a02 + a12 * a12;
    if norm <= 1e-30 {
        // Diagonal (to rounding).
        return (
            [a00 * max0, a11 * max0, a22 * max0],
            [DVec3::X, DVec3::Y, DVec3::Z],
        );
    }
    let q = (a00 + a11 + a22) / 3.0;
    let (b00, b11, b22) = (a00 - q, a11 - q, a22 - q);
    let p = ((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * norm) / 6.0).sqrt();
    let c00 = b11 * b22 - a12 * a12;
    let c01 = a01 * b22 - a12 * a02;
    let c02 = a01 * a12 - b11 * a02;
    let det = (b00 * c00 - a01 * c01 + a02 * c02) / (p * p * p);
    let half_det = (det * 0.5).clamp(-1.0, 1.0);
    let angle = half_det.acos() / 3.0;
    const TWO_THIRDS_PI: f64 = 2.0 * std::f64::consts::PI / 3.0;
    let beta2 = angle.cos() * 2.0;
    let beta0 = (angle + TWO_THIRDS_PI).cos() * 2.0;
    let beta1 = -(beta0 + beta2);
    let vals = [q + p * beta0, q + p * beta1, q + p * beta2];
    let m = [a00, a01, a02, a11, a12, a22];
    let vecs = if half_det >= 0.0 {
        let v2 = eigenvector0(m, vals[2]);
        let v1 = eigenvector1(m, v2, vals[1]);
        [v1.cross(v2), v1, v2]
    } else {
        let v0 = eigenvector0(m, vals[0]);
        let v1 = eigenvector1(m, v0, vals[1]);
        [v0, v1, v0.cross(v1)]
    };
    (vals.map(|v| v * max0), vecs)
}

/// The eigenvector of a simple eigenvalue: the longest cross product of two rows
/// of `A - λI`.
fn eigenvector0(a: [f64; 6], val: f64) -> DVec3 {
    let r0 = DVec3::new(a[0] - val, a[1], a[2]);
    let r1 = DVec3::new(a[1], a[3] - val, a[4]);
    let r2 = DVec3::new(a[2], a[4], a[5] - val);
    let c = [r0.cross(r1), r0.cross(r2), r1.cross(r2)];
    let d = c.map(|v| v.length_squared());
    let i = if d[0] >= d[1] && d[0] >= d[2] {
        0
    } else if d[1] >= d[2] {
        1
    } else {
        2
    };
    if d[i] > 0.0 {
        c[i] / d[i].sqrt()
    } else {
        DVec3::X
    }
}

/// The eigenvector of `val` orthogonal to the unit eigenvector `v0`: solved as a
/// 2x2 problem in the plane orthogonal to `v0`.
fn eigenvector1(a: [f64; 6], v0: DVec3, val: f64) -> DVec3 {
    let u = if v0.x.abs() > v0.y.abs() {
        DVec3::new(-v0.z, 0.0, v0.x) / (v0.x * v0.x + v0.z * v0.z).sqrt()
    } else {
        DVec3::new(0.0, v0.z, -v0.y) / (v0.y * v0.y + v0.z * v0.z).sqrt()
    };
    let v = v0.cross(u);
    let mul = |x: DVec3| {
        DVec3::new(
            a[0] * x.x + a[1] * x.y + a[2] * x.z,
            a[1] * x.x + a[3] * x.y + a[4] * x.z,
            a[2] * x.x + a[4] * x.y + a[5] * x.z,
        )
    };
    let (au, av) = (mul(u), mul(v));
    let m00 = u.dot(au) - val;
    let m01 = u.dot(av);
    let m11 = v.dot(av) - val;
    let (abs00, abs01, abs11) = (m00.abs(), m01.abs(), m11.abs());
    // The null direction of the 2x2 block, from its row of larger magnitude.
    if abs00 >= abs11 {
        if abs00.max(abs01) > 0.0 {
            let (m00, m01) = unit_pair(m00, m01);
            u * m01 - v * m00
        } else {
            u
        }
    } else if abs11.max(abs01) > 0.0 {
        let (m11, m01) = unit_pair(m11, m01);
        u * m11 - v * m01
    } else {
        u
    }
}

/// `(a, b)` scaled to unit length without overflow: divided through by the larger
/// magnitude first (one of them must be non-zero).
fn unit_pair(a: f64, b: f64) -> (f64, f64) {
    if a.abs() >= b.abs() {
        let r = b / a;
        let s = 1.0 / (1.0 + r * r).sqrt();
        (s, r * s)
    } else {
        let r = a / b;
        let s = 1.0 / (1.0 + r * r).sqrt();
        (r * s, s)
    }
}

/// Eigen decomposition of a symmetric 3x3 matrix (upper triangle xx, xy, xz, yy, yz,
/// zz) by cyclic Jacobi rotations. Returns eigenvalues and unit eigenvectors. The
/// reference for [`sym_eigen_closed`].
pub fn sym_eigen(a: [f64; 6]) -> ([f64; 3], [DVec3; 3]) {
    let mut m = [[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]];
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..12 {
        let off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
        let diag = m[0][0] * m[0][0] + m[1][1] * m[1][1] + m[2][2] * m[2][2];
        // Off-diagonal below 1e-6 of the diagonal (squared: 1e-12): eigenvalues to
        // about 1e-6 relative, far finer than SVD_CUTOFF needs.
        if off <= 1e-12 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            if m[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for k in 0..3 {
                let mkp = m[k][p];
                let mkq = m[k][q];
                m[k][p] = c * mkp - s * mkq;
                m[k][q] = s * mkp + c * mkq;
            }
            for k in 0..3 {
                let mpk = m[p][k];
                let mqk = m[q][k];
                m[p][k] = c * mpk - s * mqk;
                m[q][k] = s * mpk + c * mqk;
            }
            for row in v.iter_mut() {
                let vp = row[p];
                let vq = row[q];
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let vals = [m[0][0], m[1][1], m[2][2]];
    let vecs = [
        DVec3::new(v[0][0], v[1][0], v[2][0]),
        DVec3::new(v[0][1], v[1][1], v[2][1]),
        DVec3::new(v[0][2], v[1][2], v[2][2]),
    ];
    (vals, vecs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_planes_meet_at_the_corner() {
        let mut q = Qef::default();
        let corner = Vec3::new(0.3, 0.6, 0.2);
        q.add_plane(corner + Vec3::new(0.0, 0.2, 0.1), Vec3::X);
        q.add_plane(corner + Vec3::new(0.1, 0.0, 0.3), Vec3::Y);
        q.add_plane(corner + Vec3::new(0.2, 0.1, 0.0), Vec3::Z);
        let (x, e) = q.solve(Vec3::ZERO, Vec3::ONE);
        assert!((x - corner).length() < 1e-5, "{x}");
        assert!(e < 1e-10);
    }

    #[test]
    fn nearly_parallel_planes_stay_near_mass_point() {
        let mut q = Qef::default();
        q.add_plane(Vec3::new(0.2, 0.5, 0.5), Vec3::new(0.0, 0.0, 1.0));
        q.add_plane(
            Vec3::new(0.8, 0.5, 0.5),
            Vec3::new(0.01, 0.0, 1.0).normalize(),
        );
        let (x, _) = q.solve(Vec3::ZERO, Vec3::ONE);
        assert!((x - Vec3::new(0.5, 0.5, 0.5)).length() < 0.01, "{x}");
    }

    #[test]
    fn crease_outside_the_cell_stays_on_the_surface() {
        // Two planes meeting along a line just outside the unit cell (x = 1.2): the
        // free minimiser leaves the cell; the constrained one sits on the nearer
        // plane's face of the cell, not at a clamped point off both planes.
        let mut q = Qef::default();
        let n1 = Vec3::new(1.0, 1.0, 0.0).normalize();
        let n2 = Vec3::new(1.0, -1.0, 0.0).normalize();
        let apex = Vec3::new(1.2, 0.5, 0.5);
        for z in [0.2, 0.8] {
            q.add_plane(apex + Vec3::new(-0.3, 0.3, z - 0.5), n1);
            q.add_plane(apex + Vec3::new(-0.5, -0.5, z - 0.5), n2);
        }
        let (x, e) = q.solve(Vec3::ZERO, Vec3::ONE);
        let clamped = Vec3::new(1.0, 0.5, 0.5);
        assert!(e <= q.error_at(clamped.as_dvec3()) + 1e-12, "{x} {e}");
        assert!(x.cmple(Vec3::ONE).all() && x.cmpge(Vec3::ZERO).all());
    }

    #[test]
    fn error_grows_when_qefs_add() {
        let mut a = Qef::default();
        a.add_plane(Vec3::new(0.5, 0.5, 0.5), Vec3::Z);
        let mut b = Qef::default();
        b.add_plane(
            Vec3::new(1.5, 0.5, 0.7),
            Vec3::new(0.3, 0.0, 1.0).normalize(),
        );
        let ea = a.solve(Vec3::ZERO, Vec3::splat(2.0)).1;
        let mut ab = a;
        ab += &b;
        let eab = ab.solve(Vec3::ZERO, Vec3::splat(2.0)).1;
        assert!(eab >= ea);
        assert!(ab.fast_min_error() >= 0.0);
    }

    /// A small deterministic generator for the tests below.
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn closed_form_eigen_matches_jacobi_including_repeated_and_rank_deficient() {
        let mut st = 7u64;
        for case in 0..20_000 {
            // AᵀA of 1 to 6 unit normals, some nearly or exactly parallel (ranks 1
            // and 2, repeated eigenvalues), plus a few exact diagonal matrices.
            let mut q = Qef::default();
            let planes = 1 + case % 6;
            let base = DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)).normalize();
            for k in 0..planes {
                let jitter = match case % 4 {
                    0 => 0.0,
                    1 => 1e-4,
                    2 => 0.1,
                    _ => 1.0,
                };
                let n = (base + jitter * DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)))
                    .normalize();
                let n = if case % 97 == 0 {
                    [DVec3::X, DVec3::Y, DVec3::Z][k % 3]
                } else {
                    n
                };
                q.add_plane(Vec3::ZERO, n.as_vec3());
            }
            let a = q.ata;
            let (v1, e1) = sym_eigen(a);
            let (v2, e2) = sym_eigen_closed(a);
            let scale = v1.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            let mut s1 = v1;
            let mut s2 = v2;
            s1.sort_by(f64::total_cmp);
            s2.sort_by(f64::total_cmp);
            for k in 0..3 {
                // The trigonometric form loses about half the digits of a
                // nearly repeated pair (acos near ±1): 1e-8 of the largest, far
                // below the truncation at SVD_CUTOFF.
                assert!(
                    (s1[k] - s2[k]).abs() <= 1e-7 * scale,
                    "{case}: {s1:?} {s2:?}"
                );
            }
            // Orthonormal, and A v = λ v.
            let m = |x: DVec3| {
                DVec3::new(
                    a[0] * x.x + a[1] * x.y + a[2] * x.z,
                    a[1] * x.x + a[3] * x.y + a[4] * x.z,
                    a[2] * x.x + a[4] * x.y + a[5] * x.z,
                )
            };
            for i in 0..3 {
                assert!((e2[i].length() - 1.0).abs() < 1e-9, "{case}: {e2:?}");
                for j in 0..i {
                    assert!(e2[i].dot(e2[j]).abs() < 1e-9, "{case}: {e2:?}");
                }
                let r = m(e2[i]) - e2[i] * v2[i];
                assert!(r.length() <= 1e-7 * scale, "{case}: residual {r}");
            }
            // The truncated pseudo-inverse both give is the same.
            let rhs = DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st));
            let pinv = |vals: [f64; 3], vecs: [DVec3; 3]| {
                let max = vals.iter().cloned().fold(0.0f64, f64::max);
                let mut x = DVec3::ZERO;
                for k in 0..3 {
                    if vals[k] > SVD_CUTOFF * max * 1.0001 {
                        x += vecs[k] * (vecs[k].dot(rhs) / vals[k]);
                    }
                }
                x
            };
            let (x1, x2) = (pinv(v1, e1), pinv(v2, e2));
            // Jacobi stops when the off-diagonal is 1e-6 of the diagonal, so its
            // eigenvectors are good to about 1e-6 (residuals seen: 1.8e-6, where
            // the closed form's are 1e-16); compare at the reference's accuracy.
            assert!(
                (x1 - x2).length() <= 1e-4 * x1.length().max(1.0),
                "{case}: {x1} {x2}"
            );
        }
        assert_eq!(sym_eigen_closed([0.0; 6]).0, [0.0; 3]);
    }

    #[test]
    fn dominant_eigen_fast_path_agrees_with_the_closed_form() {
        let mut st = 11u64;
        let (mut taken, mut declined) = (0, 0);
        for case in 0..20_000 {
            // Nearly flat patches (the fast path's case) to creases (not its case).
            let mut q = Qef::default();
            let planes = 1 + case % 8;
            let base = DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)).normalize();
            let jitter = [0.0, 1e-6, 1e-3, 0.03, 0.08, 0.15, 0.5, 1.0][case % 8];
            for _ in 0..planes {
                let n = (base + jitter * DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)))
                    .normalize();
                q.add_plane(Vec3::ZERO, n.as_vec3());
            }
            let a = q.ata;
            let (vals, vecs) = sym_eigen_closed(a);
            let k = (0..3).max_by(|&i, &j| vals[i].total_cmp(&vals[j])).unwrap();
            let max = vals[k];
            let below = (0..3)
                .filter(|&i| i != k)
                .all(|i| vals[i] <= SVD_CUTOFF * max);
            match dominant_eigen(a) {
                Some((val, v)) => {
                    taken += 1;
                    // Only taken when the truncation keeps one direction.
                    assert!(below, "{case}: taken with eigenvalues {vals:?}");
                    assert!((val - max).abs() <= 1e-12 * max, "{case}: {val} {max}");
                    assert!(
                        (v.dot(vecs[k]).abs() - 1.0).abs() < 1e-12,
                        "{case}: {v} {}",
                        vecs[k]
                    );
                }
                None => {
                    declined += 1;
                    // Declines only what it must, or what sits at the cutoff.
                    let second = (0..3).filter(|&i| i != k).map(|i| vals[i]).sum::<f64>();
                    assert!(
                        !below || second > 0.9 * SVD_CUTOFF * max,
                        "{case}: declined {vals:?}"
                    );
                }
            }
            // And the solve through it matches the full decomposition's.
            let rhs_at = DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st));
            q.atb = q.mul(rhs_at) + DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)) * 0.01;
            let fast = q.solve_fixed(DVec3::ZERO, [false; 3]);
            let rhs = q.atb;
            let mut full = DVec3::ZERO;
            for i in 0..3 {
                if vals[i] > SVD_CUTOFF * max {
                    full += vecs[i] * (vecs[i].dot(rhs) / vals[i]);
                }
            }
            assert!(
                (fast - full).length() <= 1e-9 * full.length().max(1.0),
                "{case}: {fast} {full}"
            );
        }
        assert!(taken > 5_000 && declined > 5_000, "{taken} {declined}");
        assert_eq!(dominant_eigen([0.0; 6]), None);
        assert_eq!(dominant_eigen([f64::NAN; 6]), None);
    }

    /// The Frobenius pre-check declines only matrices the squaring declines
    /// too (so the fast path gives what it gave without it), and spares the
    /// squaring most of those: tested on planes spread around the cutoff,
    /// where the two tests are closest, and far from it.
    #[test]
    fn the_spread_check_declines_only_what_squaring_declines() {
        let mut st = 29u64;
        let (mut spared, mut declined) = (0, 0);
        for case in 0..40_000 {
            let mut q = Qef::default();
            let base = DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st)).normalize();
            // Two plane families at an angle whose eigenvalue ratio
            // (tan^2 of half of it) runs across the cutoff's 0.02.
            let angle = 0.05 + 0.6 * (case % 400) as f64 / 400.0;
            let axis = base.any_orthonormal_vector();
            let other = base * angle.cos() + axis * angle.sin();
            let planes = 2 + case % 5;
            for k in 0..planes {
                let n = if k % 2 == 0 { base } else { other };
                let n =
                    (n + 1e-3 * DVec3::new(lcg(&mut st), lcg(&mut st), lcg(&mut st))).normalize();
                q.add_plane(Vec3::ZERO, n.as_vec3());
            }
            let a = q.ata;
            let squared = dominant_eigen_by_squaring(a);
            if squared.is_none() {
                declined += 1;
            }
            if surely_spread(a) {
                spared += 1;
                assert!(squared.is_none(), "{case}: spared {a:?}, squaring took it");
            }
            assert_eq!(dominant_eigen(a), squared, "{case}");
        }
        assert!(spared > declined * 9 / 10, "{spared} of {declined}");
        assert!(declined > 10_000 && declined < 39_000, "{declined}");
        assert!(surely_spread([1.0, 0.0, 0.0, 1.0, 0.0, 0.0]));
        assert!(!surely_spread([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert_eq!(dominant_eigen([0.0; 6]), None);
        assert_eq!(dominant_eigen([f64::NAN; 6]), None);
    }

    #[test]
    fn per_axis_error_sees_the_axis() {
        let mut q = Qef::default();
        // Planes with normals along x at different x positions: error only along x.
        q.add_plane(Vec3::new(0.2, 0.5, 0.5), Vec3::X);
        q.add_plane(Vec3::new(0.8, 0.5, 0.5), Vec3::X);
        let e2 = q.error_per_axis(DVec3::new(0.5, 0.5, 0.5));
        assert!(e2.x > 0.1 && e2.y == 0.0 && e2.z == 0.0, "{e2}");
    }
}
