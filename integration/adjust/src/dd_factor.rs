//! The double-difference factor of tight coupling: the carrier phases (or the codes) of one
//! rover epoch next to an exposure, differenced against the base and a pivot satellite, as a
//! function of the projection centre, the attitude, the lever arm and — for phase — the
//! double-difference ambiguities (cycles, one block each).
//!
//! The antenna at the exposure is `X_S + R·l` (adjustment frame); the rover epoch is a few
//! hundredths of a second away, so the antenna there is that plus `shift` (the trajectory's
//! motion over the gap, which a float ambiguity does not disturb). Each row is
//! `ρ_sat(x) − ρ_pivot(x) [+ λ·N] − z` with x in ECEF, z the observed double difference minus
//! what the model knows without the rover (see `gnss::ppk::tight`). The noise model is the
//! full covariance of the double differences (rows with one pivot share its variance).

use gnss::ppk::tight::DdRow;
use nalgebra::{DMatrix, DMatrixViewMut, Matrix3, RowVector3, Vector3};
use photo::lever::LeverArm;
use photo::lsq::{Factor, Key, Params};
use photo::rotation::skew;

/// Which observable a factor holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DdKind {
    /// Carrier phase (with ambiguities).
    Phase,
    /// Code.
    Code,
}

/// One row of a factor: the double difference and where its ambiguity and ionosphere blocks
/// are among the factor's keys.
#[derive(Clone, Debug)]
pub struct FactorRow {
    /// The double difference.
    pub row: DdRow,
    /// The blocks it depends on besides position (ambiguities in cycles, ionosphere in m on
    /// the first slot): index in the keys and coefficient (λ for an ambiguity, ∓μ for the
    /// ionosphere of phase / code).
    pub terms: Vec<(usize, f64)>,
}

/// Double differences of one rover epoch tied to one image.
pub struct DdFactor {
    /// [pose, lever arm, ambiguities…].
    keys: Vec<Key>,
    /// The rows.
    rows: Vec<FactorRow>,
    kind: DdKind,
    /// ECEF of the adjustment frame's origin, and local → ECEF rotation.
    origin: Vector3<f64>,
    to_ecef: Matrix3<f64>,
    /// Antenna motion from the exposure to the rover epoch, adjustment frame (m).
    shift: Vector3<f64>,
    /// The image's index in the project.
    pub image: usize,
    /// True GPST time of the rover epoch.
    pub rover_time: hifitime::Epoch,
}

impl DdFactor {
    /// The factor of `rows` for image `image`: `keys` starts with its pose and lever arm, then
    /// the ambiguity keys that `amb` (row → index into keys) points at.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        keys: Vec<Key>,
        rows: Vec<FactorRow>,
        kind: DdKind,
        origin: Vector3<f64>,
        to_ecef: Matrix3<f64>,
        shift: Vector3<f64>,
        image: usize,
        rover_time: hifitime::Epoch,
    ) -> DdFactor {
        DdFactor {
            keys,
            rows,
            kind,
            origin,
            to_ecef,
            shift,
            image,
            rover_time,
        }
    }

    /// The rows.
    pub fn rows(&self) -> impl Iterator<Item = &DdRow> {
        self.rows.iter().map(|r| &r.row)
    }

    /// The rows whose integer blocks (ambiguity, wide lane: the keys of kind `integer`
    /// says) are all held, as `held` tells.
    pub fn rows_held(
        &self,
        integer: impl Fn(&Key) -> bool,
        held: impl Fn(&Key) -> bool,
    ) -> impl Iterator<Item = &DdRow> {
        self.rows
            .iter()
            .filter(move |r| {
                let ints = r
                    .terms
                    .iter()
                    .map(|(k, _)| &self.keys[*k])
                    .filter(|k| integer(k));
                ints.clone().count() > 0 && ints.into_iter().all(&held)
            })
            .map(|r| &r.row)
    }

    /// Phase or code.
    pub fn kind(&self) -> DdKind {
        self.kind
    }

    /// The covariance of the rows (m²): a row's own single difference plus its pivot's, the
    /// pivot's shared by the rows with the same pivot and slot.
    pub fn covariance(&self) -> DMatrix<f64> {
        let n = self.rows.len();
        let var = |r: &DdRow| match self.kind {
            DdKind::Phase => (r.sd_var_phase, r.pivot_var_phase),
            DdKind::Code => (r.sd_var_code, r.pivot_var_code),
        };
        DMatrix::from_fn(n, n, |i, j| {
            let (a, b) = (&self.rows[i].row, &self.rows[j].row);
            if i == j {
                var(a).0 + var(a).1
            } else if a.pivot == b.pivot && a.slot == b.slot {
                var(a).1
            } else {
                0.0
            }
        })
    }
}

impl Factor for DdFactor {
    photo::keys_in_field!();
    fn dim(&self) -> usize {
        self.rows.len()
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let (Some(pose), Some(l)) = (x.pose(0), x.point(1)) else {
            return false;
        };
        // An ambiguity's (or ionosphere's) column is written only in its own rows.
        for m in j.iter_mut().skip(2).flatten() {
            m.fill(0.0);
        }
        let rl = LeverArm::new(l).offset(&pose.r);
        let local = pose.centre + rl + self.shift;
        let ecef = self.origin + self.to_ecef * local;
        // d(antenna, local) / d(pose) = [−[R·l]× | I], / d(lever) = R.
        let mut dpose = DMatrix::<f64>::zeros(3, 6);
        dpose.view_mut((0, 0), (3, 3)).copy_from(&(-skew(&rl)));
        dpose
            .view_mut((0, 3), (3, 3))
            .copy_from(&Matrix3::identity());
        for (i, fr) in self.rows.iter().enumerate() {
            let row = &fr.row;
            let (range, grad) = row.range(&ecef);
            let z = match self.kind {
                DdKind::Phase => row.phase,
                DdKind::Code => row.code,
            };
            let mut v = range - z;
            for &(k, scale) in &fr.terms {
                let Some(n) = x.vector(k) else { return false };
                v += scale * n[0];
                if let Some(Some(m)) = j.get_mut(k) {
                    m[(i, 0)] += scale;
                }
            }
            r[i] = v;
            let h: RowVector3<f64> = grad.transpose() * self.to_ecef;
            if let Some(m) = &mut j[0] {
                let hp = h * &dpose;
                for c in 0..6 {
                    m[(i, c)] = hp[c];
                }
            }
            if let Some(m) = &mut j[1] {
                let hl = h * pose.r;
                for c in 0..3 {
                    m[(i, c)] = hl[c];
                }
            }
        }
        true
    }
}

/// An integer constraint on ambiguities: Σ cᵢ·Nᵢ = z (a fixed decorrelated ambiguity that
/// does not determine single ambiguities by itself).
pub struct IntegerFix {
    keys: Vec<Key>,
    coef: Vec<f64>,
    /// The integer.
    pub value: f64,
}

impl IntegerFix {
    /// The constraint Σ `coef`ᵢ·`keys`ᵢ = `value` over one-element blocks.
    pub fn new(keys: Vec<Key>, coef: Vec<f64>, value: f64) -> IntegerFix {
        IntegerFix { keys, coef, value }
    }
}

impl Factor for IntegerFix {
    photo::keys_in_field!();
    fn dim(&self) -> usize {
        1
    }
    fn evaluate(
        &self,
        x: &Params<'_>,
        r: &mut [f64],
        j: &mut [Option<DMatrixViewMut<'_, f64>>],
    ) -> bool {
        let mut s = -self.value;
        for (k, c) in self.coef.iter().enumerate() {
            let Some(v) = x.vector(k) else { return false };
            s += c * v[0];
            if let Some(Some(m)) = j.get_mut(k) {
                m[(0, 0)] = *c;
            }
        }
        r[0] = s;
        true
    }
}
