//! Tight coupling (`[gnss] coupling = "tight"`): the rover's carrier phase and code enter the
//! adjustment as double differences at every exposure, with one float ambiguity block per
//! double-difference arc, instead of the antenna positions of a PPK trajectory; after the
//! float solution the ambiguities are resolved to integers there, with the image geometry
//! in their covariance.
//!
//! Enters: the project (rover, base and navigation files of its `[gnss]` section, the antenna
//! table for the exposure times, start positions and velocities) and the frame. Leaves: the
//! double-difference factors and ambiguity blocks in the problem ([`add`]), and after
//! [`resolve`] the integer constraints: LAMBDA on the joint covariance of the ambiguities,
//! partial fixing of the decorrelated ones whose bootstrapped success rate reaches 99.9 %
//! when the ratio test passes, one constraint factor per fixed decorrelated ambiguity, a new
//! solve, and again while that fixes more. Images whose rover epoch has no double
//! differences keep their loose antenna position.

use super::dd_factor::{DdFactor, DdKind, FactorRow, IntegerFix};
use super::error::{problem_err as err, AdjustError};
use super::frame::LocalFrame;
use super::groups::{GROUP_CODE, GROUP_FIX, GROUP_IONO, GROUP_PHASE, GROUP_PRIOR};
use super::project::{Coupling, Project};
use gnss::ppk::tight::{double_differences, DdAmbiguity, DdEpoch};
use gnss::ppk::{BasePosition, PpkOptions};
use nalgebra::{DVector, Vector3};
use photo::factors::Prior;
use photo::lsq::{CameraId, FactorId, ImageId, Key, Loss, Noise, Problem, SolveError, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The kind name of the ambiguity blocks (`Key::Custom(AMBIGUITY, n)`, cycles).
pub const AMBIGUITY: &str = "ambiguity";

/// σ of an integer constraint, cycles.
const FIX_SIGMA: f64 = 1e-3;

/// The kind name of the wide-lane blocks (cycles): N₁ − N of a later slot.
pub const WIDE: &str = "wide lane";

/// What a block of tight coupling stands for: its kind ([`AMBIGUITY`], [`WIDE`], [`IONO`]),
/// the double difference of the first slot (the ionosphere's: that of its arcs), and the later
/// slot's of a wide lane.
pub type BlockId = (&'static str, DdAmbiguity, Option<DdAmbiguity>);

/// The kind name of the double-difference ionosphere blocks (m on the first slot).
pub const IONO: &str = "ionosphere";

/// The double differences of a project, read before assembling.
pub struct DdData {
    /// Per instant asked for, the image index.
    images: Vec<usize>,
    /// The double differences.
    epochs: Vec<DdEpoch>,
    /// Images without double differences and why.
    pub missing: Vec<(usize, String)>,
    /// What reading the GNSS files said.
    pub warnings: Vec<String>,
    /// Prior σ of a double-difference ionosphere (m).
    iono_sigma: f64,
}

impl DdData {
    /// The images carried by double differences.
    pub fn images(&self) -> BTreeSet<usize> {
        self.epochs.iter().map(|e| self.images[e.instant]).collect()
    }
}

/// What tight coupling put in the problem and what resolving did.
#[derive(Clone, Debug, Default)]
pub struct Tight {
    /// Every block tight coupling made (ambiguity, wide lane, ionosphere), by the `n` of its
    /// key `Key::Custom(kind, n)`.
    pub blocks: Vec<BlockId>,
    /// Per image index: its phase and code factors.
    pub factors: BTreeMap<usize, (Option<FactorId>, Option<FactorId>)>,
    /// Images without double differences (image id, why): they keep their loose antenna.
    pub missing: Vec<(String, String)>,
    /// Per fixing round: ambiguities held at integers, decorrelated ones fixed, the ratio.
    pub rounds: Vec<(usize, usize, f64)>,
    /// The integer constraints of the last round (combinations that do not determine single
    /// ambiguities).
    pub constraints: Vec<FactorId>,
    /// Ambiguities held at integers (by key `n`).
    pub fixed: BTreeSet<usize>,
    /// 3D σ of each image's projection centre from the float solution (m), by image index.
    pub sigma_float: BTreeMap<usize, f64>,
    /// What reading the GNSS files said.
    pub warnings: Vec<String>,
}

impl Tight {
    /// The integer blocks' keys (ambiguities and wide lanes).
    pub fn keys(&self) -> Vec<Key> {
        (self.blocks.iter().enumerate())
            .filter(|(_, b)| b.0 != IONO)
            .map(|(n, b)| Key::Custom(b.0, n as u32))
            .collect()
    }

    /// Integer blocks (ambiguities and wide lanes).
    pub fn integers(&self) -> usize {
        self.blocks.iter().filter(|b| b.0 != IONO).count()
    }

    /// Whether image `i`'s position is fixed: the phase double differences whose integers
    /// are all held reach at least 3 satellites besides the pivots (so they determine the
    /// position, as a partial fix does in the PPK filter).
    pub fn image_fixed(&self, pr: &Problem, i: usize) -> bool {
        let Some((Some(f), _)) = self.factors.get(&i) else {
            return false;
        };
        let Some(d) = pr.factor_as::<DdFactor>(*f) else {
            return false;
        };
        let integer = |k: &Key| matches!(k, Key::Custom(c, _) if *c == AMBIGUITY || *c == WIDE);
        let held = |k: &Key| matches!(k, Key::Custom(_, n) if self.fixed.contains(&(*n as usize)));
        let sats: BTreeSet<gnss::sv::Sv> = d.rows_held(integer, held).map(|r| r.sv).collect();
        sats.len() >= 3
    }
}

/// The double differences at the images' exposure times, when the project asks for tight
/// coupling (`None` otherwise).
pub fn load(p: &Project, antenna_of: &[Option<usize>]) -> Result<Option<DdData>, AdjustError> {
    let Some(gs) = p
        .file
        .gnss
        .as_ref()
        .filter(|g| g.coupling == Coupling::Tight)
    else {
        return Ok(None);
    };
    let dir = p.path.parent().unwrap_or(Path::new("."));
    let (Some(rover), Some(base)) = (&gs.rover, &gs.base) else {
        return Err(err(format!(
            "{}: [gnss] coupling = \"tight\" needs rover = \"…\" and base = \"…\" (observation files) and nav = \"…\"",
            p.path.display()
        )));
    };
    let g = |e: gnss::Error| err(e.to_string());
    let read = |f: &Path| gnss::obs::read_obs(&dir.join(f), None, None).map_err(g);
    let (rover, base) = (read(rover)?, read(base)?);
    let mut navs = Vec::new();
    for n in &gs.nav {
        navs.push(gnss::rinex::nav::NavFile::read(&dir.join(n)).map_err(g)?);
    }
    navs.extend(rover.nav.clone());
    if navs.is_empty() {
        return Err(err(format!(
            "{}: [gnss] coupling = \"tight\" needs nav = \"…\" (broadcast navigation files)",
            p.path.display()
        )));
    }
    let orbits = gnss::orbit::Orbits::broadcast(gnss::orbit::Ephemerides::from_nav(&navs));
    let base_pos = match gs.base_position {
        Some(b) => BasePosition::Given(gnss::frame::Ecef(Vector3::from(b))),
        None => BasePosition::Header,
    };
    let (images, instants): (Vec<usize>, Vec<_>) = antenna_of
        .iter()
        .enumerate()
        .filter_map(|(i, a)| a.map(|k| (i, p.antennas[k].time)))
        .unzip();
    let set = double_differences(
        &rover.obs,
        &base.obs,
        base_pos,
        &orbits,
        &PpkOptions::default(),
        &instants,
        smoothing_window(&instants),
    )
    .map_err(g)?;
    let km = (set.epochs.first())
        .and_then(|e| Some((p.antennas[antenna_of[images[e.instant]]?].pos.0 - set.base.0).norm()))
        .unwrap_or(0.0)
        / 1000.0;
    Ok(Some(DdData {
        iono_sigma: (gs.iono_ppm * 1e-3 * std::f64::consts::SQRT_2 * km).max(0.005),
        missing: set
            .missing
            .iter()
            .map(|(n, why)| (images[*n], why.clone()))
            .collect(),
        images,
        epochs: set.epochs,
        warnings: set.warnings,
    }))
}

/// Half the median time between consecutive exposures (at most 5 s): the code-smoothing
/// window that keeps neighbouring exposures' rows independent.
fn smoothing_window(instants: &[hifitime::Epoch]) -> f64 {
    let mut d: Vec<f64> = instants
        .windows(2)
        .map(|w| (w[1] - w[0]).abs().to_seconds())
        .filter(|d| *d > 0.0)
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2)
        .map_or(0.0, |m| (0.5 * m - 1e-3).clamp(0.0, 5.0))
}

/// Add the double-difference factors and ambiguity blocks (and a lever-arm block where the
/// loose factors did not add one).
pub fn add(
    p: &Project,
    frame: &LocalFrame,
    pr: &mut Problem,
    data: DdData,
    antenna_of: &[Option<usize>],
) -> Result<Tight, AdjustError> {
    let built = |e: photo::lsq::BuildError| err(e.to_string());
    let mut t = Tight {
        missing: data
            .missing
            .iter()
            .map(|(i, why)| (p.images[*i].id.clone(), why.clone()))
            .collect(),
        warnings: data.warnings.clone(),
        ..Default::default()
    };
    let mut index: BTreeMap<BlockId, usize> = BTreeMap::new();
    let to_ecef = frame.rot.transpose();
    for e in &data.epochs {
        let i = data.images[e.instant];
        let Some(k) = antenna_of[i] else { continue };
        if !pr.contains(Key::Pose(ImageId::from(i))) {
            continue;
        }
        let cam = CameraId::from(p.images[i].camera);
        lever_arm_block(p, pr, cam).map_err(built)?;
        let ant = &p.antennas[k];
        let dt = (e.rover_time - ant.time).to_seconds();
        let vel = velocity(p, antenna_of, i).unwrap_or_default();
        let shift = frame.from_enu_at(&ant.pos) * vel * dt;
        let x0 = ant.pos.0 + to_ecef * shift;
        let mut keys = vec![Key::Pose(ImageId::from(i)), Key::LeverArm(cam)];
        let mut blocks = Blocks {
            pr: &mut *pr,
            t: &mut t,
            index: &mut index,
            iono_sigma: data.iono_sigma,
        };
        let (phase, code) = blocks.rows(e, &x0, &mut keys).map_err(built)?;
        let mut ids = (None, None);
        for (kind, rows, keys) in [
            (DdKind::Phase, phase, keys.clone()),
            (DdKind::Code, code, keys.clone()),
        ] {
            if rows.len() < 2 {
                continue;
            }
            let f = DdFactor::new(
                keys,
                rows,
                kind,
                frame.origin.0,
                to_ecef,
                shift,
                i,
                e.rover_time,
            );
            let noise = Noise::covariance(&f.covariance()).ok_or_else(|| {
                err(format!(
                    "image {}: the double differences' covariance is not positive definite",
                    p.images[i].id
                ))
            })?;
            let (group, slot) = match kind {
                DdKind::Phase => (GROUP_PHASE, &mut ids.0),
                DdKind::Code => (GROUP_CODE, &mut ids.1),
            };
            *slot = Some(
                pr.add_factor(f, noise, Loss::Trivial, group)
                    .map_err(built)?,
            );
        }
        t.factors.insert(i, ids);
    }
    Ok(t)
}

/// Where the ambiguity and ionosphere blocks are made.
struct Blocks<'a> {
    pr: &'a mut Problem,
    t: &'a mut Tight,
    /// Block identity → n of its key.
    index: &'a mut BTreeMap<BlockId, usize>,
    iono_sigma: f64,
}

impl Blocks<'_> {
    /// The phase and code rows of epoch `e`, their ambiguity and ionosphere blocks added to
    /// `keys` (made when new, with a start value from the antenna `x0`).
    #[allow(clippy::type_complexity)]
    fn rows(
        &mut self,
        e: &DdEpoch,
        x0: &Vector3<f64>,
        keys: &mut Vec<Key>,
    ) -> Result<(Vec<FactorRow>, Vec<FactorRow>), photo::lsq::BuildError> {
        // One ionosphere per satellite, pivot and arc of the first slot.
        let iono_key = |sv: gnss::sv::Sv| -> Option<DdAmbiguity> {
            let rows = || e.rows.iter().filter(|r| r.sv == sv);
            let a = (rows().find(|r| r.slot == 0).and_then(|r| r.ambiguity))
                .or_else(|| rows().find_map(|r| r.ambiguity))?;
            Some(DdAmbiguity { slot: 0, ..a })
        };
        let (mut phase, mut code) = (Vec::new(), Vec::new());
        for row in &e.rows {
            let mut terms = Vec::new();
            if let Some(a) = iono_key(row.sv) {
                terms.push((self.block(IONO, a, None, 0.0, keys)?, row.iono_scale));
            }
            if row.code.is_finite() {
                code.push(FactorRow {
                    row: row.clone(),
                    terms: terms.clone(),
                });
            }
            let (Some(a), true) = (row.ambiguity, row.phase.is_finite()) else {
                continue;
            };
            for t in &mut terms {
                t.1 = -t.1;
            }
            let float = (row.phase - row.range(x0).0) / row.wavelength;
            // Beyond the first slot: N = N₁ − N_w with the wide lane N_w as the block, when
            // the first slot has phase here.
            let first = (e.rows.iter())
                .find(|r| r.sv == row.sv && r.slot == 0 && r.phase.is_finite())
                .and_then(|r| Some((r, r.ambiguity?)));
            match (row.slot, first) {
                (1.., Some((r1, a1))) => {
                    let f1 = (r1.phase - r1.range(x0).0) / r1.wavelength;
                    let n1 = self.block(AMBIGUITY, a1, None, f1, keys)?;
                    let w = self.block(WIDE, a1, Some(a), f1 - float, keys)?;
                    terms.push((n1, row.wavelength));
                    terms.push((w, -row.wavelength));
                }
                _ => terms.push((self.block(AMBIGUITY, a, None, float, keys)?, row.wavelength)),
            }
            phase.push(FactorRow {
                row: row.clone(),
                terms,
            });
        }
        Ok((phase, code))
    }

    /// The index in `keys` of the block of kind `kind` (ambiguity, wide lane or ionosphere)
    /// for `a` (and the second slot's `b` of a wide lane), made when new with value `start`
    /// (an ionosphere with its prior).
    fn block(
        &mut self,
        kind: &'static str,
        a: DdAmbiguity,
        b: Option<DdAmbiguity>,
        start: f64,
        keys: &mut Vec<Key>,
    ) -> Result<usize, photo::lsq::BuildError> {
        let id = (kind, a, b);
        let n = match self.index.get(&id) {
            Some(n) => *n,
            None => {
                let n = self.t.blocks.len();
                let key = Key::Custom(kind, n as u32);
                let v = Value::Vector(DVector::from_element(1, start));
                self.pr.add_block(key, v)?;
                if kind == IONO {
                    let f = Prior::new(key, DVector::zeros(1));
                    let noise = Noise::sigmas(&[self.iono_sigma]);
                    self.pr.add_factor(f, noise, Loss::Trivial, GROUP_IONO)?;
                }
                self.t.blocks.push(id);
                self.index.insert(id, n);
                n
            }
        };
        let key = Key::Custom(kind, n as u32);
        Ok(match keys.iter().position(|k| *k == key) {
            Some(p) => p,
            None => {
                keys.push(key);
                keys.len() - 1
            }
        })
    }
}

/// The lever-arm block of camera `cam`, added with the project's prior when missing.
fn lever_arm_block(
    p: &Project,
    pr: &mut Problem,
    cam: CameraId,
) -> Result<(), photo::lsq::BuildError> {
    let key = Key::LeverArm(cam);
    let Some(gs) = p.file.gnss.as_ref() else {
        return Ok(());
    };
    if pr.contains(key) {
        return Ok(());
    }
    pr.add_block(
        key,
        Value::Vector(DVector::from_column_slice(&gs.lever_arm)),
    )?;
    pr.set_fixed(key, !gs.estimate_lever_arm)?;
    if let (Some(s), true) = (gs.lever_arm_sigma, gs.estimate_lever_arm) {
        let sig: Vec<f64> = s.iter().map(|x| x.max(1e-6)).collect();
        let f = Prior::new(key, DVector::from_column_slice(&gs.lever_arm));
        pr.add_factor(f, Noise::sigmas(&sig), Loss::Trivial, GROUP_PRIOR)?;
    }
    Ok(())
}

/// The antenna's velocity at image `i` (local ENU at the antenna, m/s): the table's, else
/// from the antenna positions of the images exposed just before and after (within 3 s).
fn velocity(p: &Project, antenna_of: &[Option<usize>], i: usize) -> Option<Vector3<f64>> {
    let a = &p.antennas[antenna_of[i]?];
    if let Some(v) = a.vel_enu {
        return Some(v);
    }
    let near = |j: usize| -> Option<&super::input::Antenna> {
        let b = &p.antennas[(*antenna_of.get(j)?)?];
        ((b.time - a.time).abs().to_seconds() <= 3.0 && j != i).then_some(b)
    };
    let (b, c) = match (i.checked_sub(1).and_then(near), near(i + 1)) {
        (Some(b), Some(c)) => (b, c),
        (Some(b), None) => (b, a),
        (None, Some(c)) => (a, c),
        (None, None) => return None,
    };
    let dt = (c.time - b.time).to_seconds();
    let r = gnss::frame::enu_rotation(&a.pos.to_geodetic());
    (dt.abs() > 1e-3).then(|| r * (c.pos.0 - b.pos.0) / dt)
}

/// Resolve the ambiguities to integers: float covariance → LAMBDA → partial fix of the
/// decorrelated ambiguities → the original ones that this determines (conditional σ below
/// 0.01 cycles) held at their integers → solve; repeated on the ones still free while a
/// round holds more. `ratio_min`: the ratio test's threshold; `p_min`: the bootstrapped
/// success rate a fixed subset must reach.
pub fn resolve(
    pr: &mut Problem,
    t: &mut Tight,
    ratio_min: f64,
    p_min: f64,
) -> Result<(), SolveError> {
    let build = |e: photo::lsq::BuildError| SolveError::Singular(e.to_string());
    for _round in 0..8 {
        // The last round's constraints are replaced by this round's.
        for id in std::mem::take(&mut t.constraints) {
            pr.remove(id);
        }
        let keys: Vec<Key> = (t.keys().into_iter())
            .filter(|k| pr.contains(*k) && !pr.is_fixed(*k))
            .collect();
        let Some(q) = (!keys.is_empty())
            .then(|| pr.joint_covariance(&keys, 1.0))
            .transpose()?
            .flatten()
        else {
            break;
        };
        let a: Vec<f64> = keys.iter().map(|k| scalar(pr, *k)).collect();
        let Some(round) = fix_round(&a, &q, ratio_min, p_min) else {
            break;
        };
        for (i, v) in &round.held {
            let (k, v) = (keys[*i], Value::Vector(DVector::from_element(1, *v)));
            pr.set_value(k, v).map_err(build)?;
            pr.set_fixed(k, true).map_err(build)?;
            if let Key::Custom(_, n) = k {
                t.fixed.insert(n as usize);
            }
        }
        let held: BTreeSet<usize> = round.held.iter().map(|h| h.0).collect();
        for (coef, value) in &round.combos {
            let (mut ks, mut cs, mut z) = (Vec::new(), Vec::new(), *value);
            for (i, c) in coef.iter().enumerate().filter(|(_, c)| **c != 0.0) {
                if held.contains(&i) {
                    z -= c * scalar(pr, keys[i]);
                } else {
                    ks.push(keys[i]);
                    cs.push(*c);
                }
            }
            if ks.is_empty() || ks.len() > photo::lsq::MAX_FACTOR_KEYS {
                continue;
            }
            let f = IntegerFix::new(ks, cs, z);
            let id = pr
                .add_factor(f, Noise::sigmas(&[FIX_SIGMA]), Loss::Trivial, GROUP_FIX)
                .map_err(build)?;
            t.constraints.push(id);
        }
        t.rounds
            .push((round.held.len(), round.combos.len(), round.ratio));
        pr.solve()?;
        if round.held.is_empty() {
            break;
        }
    }
    Ok(())
}

/// What one fixing round decided.
struct Round {
    /// Ambiguities determined by the fixed subset: index and integer.
    held: Vec<(usize, f64)>,
    /// The fixed decorrelated ambiguities: coefficients over all and integer.
    combos: Vec<(Vec<f64>, f64)>,
    /// The ratio test's value.
    ratio: f64,
}

/// One round on float ambiguities `a` with covariance `q`: the decorrelated subset that
/// passes (success rate, then ratio test), the float vector conditioned on it, and the
/// ambiguities it determines (index, integer) with the ratio; None when nothing passes.
fn fix_round(a: &[f64], q: &nalgebra::DMatrix<f64>, ratio_min: f64, p_min: f64) -> Option<Round> {
    let dec = gnss::ppk::lambda::decorrelate(a, q.as_slice())?;
    let n = dec.n;
    let mut k = dec.most_fixable(p_min);
    let c = loop {
        if k == 0 {
            return None;
        }
        match dec.search_last(k, 2) {
            Some(c) if c.ratio() >= ratio_min => break c,
            _ => k -= 1,
        }
    };
    // a|z = a − Q·Z_k·(Z_kᵀ·Q·Z_k)⁻¹·(Z_kᵀ·a − ž), Q|z = Q − Q·Z_k·(Z_kᵀ·Q·Z_k)⁻¹·Z_kᵀ·Q.
    let zk = nalgebra::DMatrix::from_fn(n, k, |i, j| dec.z_column(n - k + j)[i]);
    let av = DVector::from_column_slice(a);
    let zf = DVector::from_column_slice(&c.fixes[0]);
    let qz = q * &zk;
    let inv = (zk.transpose() * &qz).try_inverse()?;
    let gain = &qz * inv;
    let cond = &av - &gain * (zk.transpose() * &av - zf);
    let qc = q - &gain * qz.transpose();
    let held = (0..n)
        .filter(|&i| qc[(i, i)].max(0.0).sqrt() < 0.01)
        .map(|i| (i, cond[i].round()))
        .collect();
    let combos = (0..k)
        .map(|j| (dec.z_column(n - k + j).to_vec(), c.fixes[0][j]))
        .collect();
    Some(Round {
        held,
        combos,
        ratio: c.ratio(),
    })
}

/// The 3D σ of the projection centre of every image with double differences (m), at the
/// current solution (σ0 = 1).
pub fn centre_sigmas(pr: &Problem, t: &Tight) -> Result<BTreeMap<usize, f64>, SolveError> {
    let keys: Vec<Key> = (t.factors.keys())
        .map(|i| Key::Pose(ImageId::from(*i)))
        .collect();
    let cov = pr.covariances(&keys, 1.0)?;
    Ok(t.factors
        .keys()
        .zip(&cov)
        .filter_map(|(i, c)| {
            let c = c.as_ref()?;
            Some((*i, (c[(3, 3)] + c[(4, 4)] + c[(5, 5)]).sqrt()))
        })
        .collect())
}

/// The value of a one-element vector block.
fn scalar(pr: &Problem, k: Key) -> f64 {
    match pr.value(k) {
        Some(Value::Vector(v)) if !v.is_empty() => v[0],
        _ => f64::NAN,
    }
}
