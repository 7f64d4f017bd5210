//! The options of the carrier-phase engine: resolution mode, passes, noise and thresholds of
//! the filter, and where the base antenna is.
//!
//! What enters: nothing (plain settings, units in each field's doc). What leaves: the
//! [`PpkOptions`] every stage of a pass reads, and the [`BasePosition`] the run starts from;
//! this module uses none of the stages.

use crate::frame::Ecef;
use crate::model::antex::Antex;
use crate::sv::Constellation;

/// Integer ambiguity resolution mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArMode {
    /// Float ambiguities only.
    Off,
    /// Resolve every epoch; the filter keeps float ambiguities.
    Continuous,
    /// Resolve every epoch from that epoch's data alone.
    Instantaneous,
    /// Resolve, then constrain the filter to the fixed integers.
    FixAndHold,
}

/// Which passes to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterMode {
    /// Forward in time only.
    Forward,
    /// Backward in time only.
    Backward,
    /// Forward and backward, combined epoch by epoch.
    Combined,
}

/// How the rover moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// Every epoch is an independent position (no dynamics model).
    Kinematic,
    /// One position over the whole span: the filter runs forward and accumulates it; each
    /// epoch's output is the solution so far.
    Static,
}

/// The point of the rover that the output positions describe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// The antenna reference point (ARP): the marker plus the header's `ANTENNA: DELTA H/E/N`.
    Arp,
    /// The marker: the ARP minus the header's `ANTENNA: DELTA H/E/N`.
    Marker,
}

/// Whether an atmospheric delay is estimated by the filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimate {
    /// When the baseline is long: some rover epoch lies beyond
    /// [`PpkOptions::long_baseline`] from the base.
    Auto,
    /// Never: the a-priori model only.
    Off,
    /// Always.
    On,
}

impl Estimate {
    /// Whether the delay is estimated for a run whose longest baseline is `baseline` metres.
    pub fn resolve(self, baseline: f64, long_baseline: f64) -> bool {
        match self {
            Estimate::Auto => baseline > long_baseline,
            Estimate::Off => false,
            Estimate::On => true,
        }
    }
}

/// Options of the carrier-phase engine.
#[derive(Clone, Debug)]
pub struct PpkOptions {
    /// Kinematic or static rover.
    pub motion: Motion,
    /// The point of the rover the output positions describe.
    pub refer: Reference,
    /// Elevation mask, radians.
    pub elev_mask: f64,
    /// Systems used.
    pub systems: Vec<Constellation>,
    /// Frequency slots used (1–3).
    pub nf: usize,
    /// Integer ambiguity resolution mode.
    pub ar: ArMode,
    /// Which passes run.
    pub filter: FilterMode,
    /// Ratio-test threshold (second best / best squared distance).
    pub ratio_threshold: f64,
    /// Ratio-test threshold of the two-filter smoother's fixes, which must also agree with
    /// what the data before and after the epoch fix alone.
    pub smoothed_ratio_threshold: f64,
    /// Largest base-rover time difference, seconds.
    pub max_age: f64,
    /// Gap after which an ambiguity is reset, seconds (0: five rover intervals, at least 5 s).
    pub max_gap: f64,
    /// Undifferenced phase sigma √(a² + (b/sin el)²), metres (a, b).
    pub phase_sigma: (f64, f64),
    /// Code sigma over phase sigma.
    pub code_phase_ratio: f64,
    /// Carrier-to-noise weighting: the sigma (phase m, code m) of the noise a signal carries
    /// in excess when its C/N0 lies d dB below what its receiver normally sees at that
    /// elevation (learnt from the data, `ppk::snr`), σ²·(10^(d/10) − 1): σ at 3 dB below,
    /// 5.5σ at 15 dB below (thermal noise, and the multipath and diffraction that lower C/N0
    /// under trees). Nothing where a file has no C/N0 (the S observables).
    pub snr_sigma: (f64, f64),
    /// Correlation time of that excess phase noise (multipath), seconds: each epoch's excess
    /// variance is multiplied by it over the rover's interval, as for the code.
    pub phase_correlation_s: f64,
    /// Correlation time of code errors (multipath), seconds: epochs closer than this are not
    /// independent, so each epoch's code variance is multiplied by it over the rover's
    /// interval (10 at 1 Hz for 10 s): the float solution then averages code as the errors
    /// allow, not as white noise would (0: white).
    pub code_correlation_s: f64,
    /// The rover's nominal interval, seconds (0: taken from the data by the run).
    pub interval_s: f64,
    /// Frequency slots of a system whose ambiguities stay float: the run adds those where rover
    /// and base track different signals of a band (L2W against L2X) whose phases may differ by
    /// a quarter or half cycle (RINEX 3.04 Table A23) because not both files declare them
    /// aligned (`SYS / PHASE SHIFT`).
    pub float_slots: Vec<(Constellation, usize)>,
    /// Prior sigma of the GLONASS inter-channel code bias between the two receivers, metres
    /// per frequency channel number (estimated, one state, when GLONASS is processed: code
    /// biases of different receivers differ by up to metres across the channels).
    pub glonass_code_bias_sigma: f64,
    /// Slots whose code rover and base take from different signals (C1W against C1C): each
    /// satellite's code carries its own bias between the two (P1−C1), estimated per
    /// satellite. Filled by the run from the headers.
    pub code_bias_slots: Vec<(Constellation, usize)>,
    /// Prior sigma of such a satellite's bias, metres (the published P1−C1 biases of GPS
    /// satellites spread by about 1 ns, 0.3 m).
    pub code_bias_sigma: f64,
    /// Growth of the single-difference sigma with the age of the base epoch, m/s per
    /// (1 + baseline/10 km): a rover epoch matched to a base epoch 30 s away on a 115 km
    /// baseline weighs as if its sigma were 0.37 m (the base's atmosphere of another moment);
    /// 0.5 s of a 1 Hz base on 5 km adds 0.8 mm.
    pub age_error_rate: f64,
    /// Ambiguity random walk, cycles/√s.
    pub amb_process_noise: f64,
    /// Initial ambiguity sigma, cycles.
    pub amb_init_sigma: f64,
    /// Innovation gate, metres.
    pub max_innovation: f64,
    /// Post-fit phase residual that resets an ambiguity, metres.
    pub max_phase_residual: f64,
    /// Epochs an ambiguity must be locked before it may be fixed.
    pub min_lock: usize,
    /// Lock count below which a satellite counts as newly risen for partial fixing.
    pub mature_lock: usize,
    /// Elevation mask of the ambiguities fixed, radians.
    pub ar_elev_mask: f64,
    /// Bootstrapped success rate the fixed subset of ambiguities must reach.
    pub min_success_rate: f64,
    /// A fix whose 3D position sigma exceeds this (m) is reported as float: in a weak
    /// geometry (five satellites, long baseline) the integers may be right and the position
    /// still decimetres off. None: [`DEFAULT_FIXED_SIGMA`], with the exception of
    /// [`PpkOptions::weak_held_fixes_stand`].
    pub max_fixed_sigma: Option<f64>,
    /// Fewest double-difference ambiguities for a fix.
    pub min_fix_ambiguities: usize,
    /// Keep float the ambiguity of a phase whose half-cycle ambiguity the receiver has not
    /// resolved (RINEX LLI bit 1; u-blox trkStat halfCyc not set, MSM and SBF half-cycle
    /// flags): such a phase may be half a cycle off, so its double differences are not
    /// integers and fixing them gives wrong integers. On by default; off only to show what it
    /// prevents.
    pub half_cycle_float: bool,
    /// Interpolate base epochs into the gaps of the base's log (up to twice `max_age` across)
    /// for the rover epochs that fall in them, instead of pairing those with an aged base
    /// epoch (see `ppk::interp`). On by default; off only to show what it gains.
    pub interpolate_base: bool,
    /// Hold the position from one epoch to the next where the carrier phase says the rover
    /// stood still (see `ppk::still`), instead of starting it afresh from the code solution
    /// (kinematic runs). On by default; off only to show what it gains.
    pub use_stillness: bool,
    /// Random walk of the position while the rover stands still, m/√s: the sway of a
    /// hand-held pole.
    pub still_sigma: f64,
    /// Variance of the fix-and-hold constraint, cycles².
    pub hold_variance: f64,
    /// Estimate a single-difference slant ionospheric delay per satellite (the
    /// ionosphere-weighted model: its prior and random walk grow with the baseline).
    pub iono: Estimate,
    /// Prior sigma of that delay per km of baseline, metres (at least 2 mm).
    pub iono_sigma_per_km: f64,
    /// Its random walk per km of baseline, m/√s.
    pub iono_process_noise_per_km: f64,
    /// Estimate the rover's zenith wet delay on top of the a-priori model (one state, a random
    /// walk, mapped with Niell's wet function).
    pub tropo: Estimate,
    /// Prior sigma of that zenith delay, metres.
    pub tropo_sigma: f64,
    /// Its random walk, m/√s.
    pub tropo_process_noise: f64,
    /// Baseline length beyond which [`Estimate::Auto`] models are estimated, metres.
    pub long_baseline: f64,
    /// Sigma (horizontal, vertical; metres) of the phase-centre error between two antennas of
    /// different types when they are not both calibrated (`antex`): their offsets and
    /// variations differ by centimetres, which no double difference removes. Added in
    /// quadrature to every epoch's covariance in that case.
    pub uncalibrated_antenna_sigma: (f64, f64),
    /// Sigma (horizontal, vertical; metres) of the time-correlated errors (multipath,
    /// troposphere and orbit residuals, antenna variations) that a static solution keeps
    /// however long the span: the filter treats epochs as independent and its own σ shrinks
    /// without bound. Added in quadrature to a static run's covariance, together with
    /// `static_sigma_per_km` × baseline.
    pub static_sigma: (f64, f64),
    /// Growth of `static_sigma` with the baseline length (horizontal, vertical), metres per
    /// kilometre (0.00004 = 0.04 ppm).
    pub static_sigma_per_km: (f64, f64),
    /// Receiver antenna calibrations (ANTEX); the header antenna types are looked up in it.
    pub antex: Option<std::sync::Arc<Antex>>,
}

impl Default for PpkOptions {
    fn default() -> Self {
        PpkOptions {
            motion: Motion::Kinematic,
            refer: Reference::Arp,
            elev_mask: 10f64.to_radians(),
            systems: [Constellation::CDMA.as_slice(), &[Constellation::Glonass]].concat(),
            nf: 2,
            ar: ArMode::FixAndHold,
            filter: FilterMode::Combined,
            ratio_threshold: 3.0,
            smoothed_ratio_threshold: 2.0,
            max_age: 30.0,
            max_gap: 0.0,
            phase_sigma: (0.003, 0.003),
            code_phase_ratio: 100.0,
            snr_sigma: (0.005, 0.6),
            phase_correlation_s: 2.0,
            code_correlation_s: 10.0,
            interval_s: 0.0,
            glonass_code_bias_sigma: 0.3,
            code_bias_slots: Vec::new(),
            code_bias_sigma: 0.5,
            float_slots: Vec::new(),
            age_error_rate: 0.001,
            amb_process_noise: 1e-4,
            amb_init_sigma: 30.0,
            max_innovation: 30.0,
            max_phase_residual: 0.1,
            min_lock: 1,
            mature_lock: 5,
            ar_elev_mask: 10f64.to_radians(),
            min_success_rate: 0.999,
            max_fixed_sigma: None,
            min_fix_ambiguities: 4,
            half_cycle_float: true,
            interpolate_base: true,
            use_stillness: true,
            still_sigma: 0.005,
            hold_variance: 0.001,
            iono: Estimate::Auto,
            iono_sigma_per_km: 0.004,
            iono_process_noise_per_km: 1e-4,
            tropo: Estimate::Auto,
            tropo_sigma: 0.15,
            tropo_process_noise: 3e-5,
            long_baseline: 10_000.0,
            uncalibrated_antenna_sigma: (0.01, 0.02),
            static_sigma: (0.003, 0.006),
            static_sigma_per_km: (0.00004, 0.0001),
            antex: None,
        }
    }
}

/// The largest 3D σ of a fix (m) unless the user says: BELL–EBRE's weak-geometry fixes
/// above it lie up to 14 cm off (0.12 adds three fixed epochs beyond 10 cm there), and the
/// low-cost walk's fresh L1 fixes above it up to 0.96 m.
pub const DEFAULT_FIXED_SIGMA: f64 = 0.08;

impl PpkOptions {
    /// The largest 3D σ (m) of an epoch fixed afresh: the user's, else
    /// [`DEFAULT_FIXED_SIGMA`].
    pub fn fixed_sigma_limit(&self) -> f64 {
        self.max_fixed_sigma.unwrap_or(DEFAULT_FIXED_SIGMA)
    }

    /// Whether a fix over [`PpkOptions::fixed_sigma_limit`] may stand when every integer
    /// in it continues an arc held since a stronger geometry fixed it: by default on short
    /// baselines, where the integers leave no model error behind and the larger σ of the
    /// weak geometry (GEONET's five satellites at a 15° mask: 11 cm, 7.5 cm off) tells the
    /// truth; never where the ionosphere is estimated or the user gave a limit.
    pub fn weak_held_fixes_stand(&self) -> bool {
        self.max_fixed_sigma.is_none() && self.iono != Estimate::On
    }
}

/// Where the base antenna is.
#[derive(Clone, Copy, Debug)]
pub enum BasePosition {
    /// Given by the user (marker, ECEF).
    Given(Ecef),
    /// The header's approximate position (warned about loudly).
    Header,
}
