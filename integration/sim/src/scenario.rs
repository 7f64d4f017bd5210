//! The scenario of a simulated flight: its TOML schema (every key checked, unknown keys
//! refused), the defaults of the optional keys and the validation of every value with its key
//! named. Enters: TOML text (or a built-in, see [`super::builtin`](mod@super::builtin)). Leaves: a checked
//! [`Scenario`], its start epoch (GPST), the flight plan ([`FlightPlan`]) and the camera
//! ([`CameraSpec`]) the simulator runs on.
//!
//! Frames and units: the site is geodetic (degrees, ellipsoidal height in metres); the base
//! and the flight are placed in the east-north-up frame at the site; lengths are metres,
//! speeds m/s, times seconds.

use super::camera::CameraSpec;
use super::error::SimError;
use super::flight::FlightPlan;
use gnss::sv::Constellation;
use hifitime::Epoch;
use nalgebra::Vector3;
use serde::Deserialize;

fn d_seed() -> u64 {
    1
}
fn d_rate() -> f64 {
    10.0
}
fn d_static() -> f64 {
    60.0
}
fn d_base_rate() -> f64 {
    1.0
}
fn d_true() -> bool {
    true
}
fn d_code() -> f64 {
    0.3
}
fn d_phase() -> f64 {
    0.002
}
fn d_img() -> f64 {
    0.5
}
fn d_mask() -> f64 {
    5.0
}
fn d_systems() -> Vec<SimSystem> {
    vec![SimSystem::Gps, SimSystem::Galileo]
}

/// A simulation scenario (every key is checked; unknown keys are errors).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name of the scenario (for reports).
    pub name: String,
    /// Seed of every random draw (default 1): the same seed gives the same files.
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// Start of the flight, GPST, `YYYY-MM-DDTHH:MM:SS`.
    pub start: String,
    /// Where the flight takes place.
    pub site: Site,
    /// The flight pattern.
    pub flight: FlightSpec,
    /// The aerial camera.
    pub camera: CameraToml,
    /// The base station.
    pub base: BaseSpec,
    /// Ground control, check and tie points.
    pub ground: GroundSpec,
    /// Which errors are simulated (all on by default).
    #[serde(default)]
    pub errors: ErrorModel,
    /// Which satellite systems are simulated (GPS and Galileo by default).
    #[serde(default)]
    pub gnss: GnssSpec,
}

/// A satellite system the simulator can broadcast, named in the scenario by its RINEX letter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum SimSystem {
    /// `G`: GPS-like, 24 satellites (6 planes × 4), L1 C/A and L2 P(Y).
    #[serde(rename = "G")]
    Gps,
    /// `E`: Galileo-like, 24 satellites (3 planes × 8), E1 and E5a.
    #[serde(rename = "E")]
    Galileo,
    /// `R`: GLONASS-like, 24 satellites (3 planes × 8) on FDMA channels −7…6, L1 and L2 C/A.
    #[serde(rename = "R")]
    Glonass,
    /// `J`: QZSS-like, 3 quasi-zenith satellites and 1 geostationary one over Japan, L1 C/A
    /// and L2C.
    #[serde(rename = "J")]
    Qzss,
}

impl SimSystem {
    /// The system as `gnss` names it.
    pub fn constellation(self) -> Constellation {
        match self {
            SimSystem::Gps => Constellation::Gps,
            SimSystem::Galileo => Constellation::Galileo,
            SimSystem::Glonass => Constellation::Glonass,
            SimSystem::Qzss => Constellation::Qzss,
        }
    }
}

/// The satellite systems of a scenario (the optional section `[gnss]`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSpec {
    /// Systems by RINEX letter, each at most once: any of `"G"`, `"E"`, `"R"`, `"J"` (default
    /// `["G", "E"]`). QZSS is seen from East Asia and Oceania only.
    #[serde(default = "d_systems")]
    pub systems: Vec<SimSystem>,
}

impl Default for GnssSpec {
    fn default() -> Self {
        GnssSpec {
            systems: d_systems(),
        }
    }
}

/// The site: origin of the local east-north-up frame.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Site {
    /// Latitude, degrees (within ±85°).
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Ellipsoidal height of the terrain, metres.
    pub ground_height: f64,
}

/// The flight: parallel strips centred on the site.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlightSpec {
    /// Above the terrain, metres.
    pub altitude: f64,
    /// Cruise speed, m/s.
    pub speed: f64,
    /// Number of strips (1–100).
    pub strips: usize,
    /// Length of each strip, metres.
    pub strip_length: f64,
    /// Distance between neighbouring strips, metres.
    pub strip_spacing: f64,
    /// Strip direction, degrees from north.
    pub heading_deg: f64,
    /// Rover observation rate, Hz (≤ 20).
    #[serde(default = "d_rate")]
    pub rate_hz: f64,
    /// Seconds on the ground before take-off.
    #[serde(default = "d_static")]
    pub static_start_s: f64,
}

/// The camera as the scenario gives it (the simulator converts it to metres).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraToml {
    /// Principal distance, millimetres.
    pub focal_mm: f64,
    /// Sensor size in pixels: x along track, y across track.
    pub width_px: usize,
    /// Sensor size across track, pixels.
    pub height_px: usize,
    /// Pixel size, micrometres.
    pub pixel_um: f64,
    /// Forward overlap of consecutive images (0–0.95).
    pub forward_overlap: f64,
    /// Antenna phase centre in the camera frame (x forward, y left, z up), metres.
    pub lever_arm: [f64; 3],
}

/// The base station, placed in the site's ENU frame.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseSpec {
    /// Position east of the site origin, metres.
    pub east: f64,
    /// Position north of the site origin, metres.
    pub north: f64,
    /// Antenna height above the site's terrain height, metres.
    pub height_above_ground: f64,
    /// Observation interval, seconds.
    #[serde(default = "d_base_rate")]
    pub interval_s: f64,
}

/// How many ground points of each kind, and the terrain.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    /// Ground control points (the first four at the block corners).
    pub gcps: usize,
    /// Check points.
    pub checks: usize,
    /// Tie points.
    pub ties: usize,
    /// Terrain relief (± metres).
    pub relief: f64,
}

/// Error model; every part can be switched off.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorModel {
    /// Receiver clock offsets and drifts (receiver time tags = true time + offset).
    #[serde(default = "d_true")]
    pub receiver_clock: bool,
    /// Saastamoinen troposphere delay.
    #[serde(default = "d_true")]
    pub troposphere: bool,
    /// Klobuchar ionosphere delay, scaled by frequency.
    #[serde(default = "d_true")]
    pub ionosphere: bool,
    /// Code noise at zenith, metres (0 = off).
    #[serde(default = "d_code")]
    pub code_noise: f64,
    /// Phase noise at zenith, metres (0 = off).
    #[serde(default = "d_phase")]
    pub phase_noise: f64,
    /// Elevation-dependent sinusoidal multipath.
    #[serde(default = "d_true")]
    pub multipath: bool,
    /// Random integer carrier-phase ambiguities (off: zero).
    #[serde(default = "d_true")]
    pub ambiguities: bool,
    /// Cycle slips injected in the rover (with LLI set).
    #[serde(default)]
    pub cycle_slips: usize,
    /// Data gaps (5–30 s of one satellite) injected in the rover.
    #[serde(default)]
    pub gaps: usize,
    /// Image measurement noise, pixels.
    #[serde(default = "d_img")]
    pub image_noise_px: f64,
    /// Gross errors (10–30 pixels) injected in the image measurements.
    #[serde(default)]
    pub image_blunders: usize,
    /// Elevation below which the rover tracks nothing, degrees (default 5; a hard sky —
    /// valleys, banking, a fuselage — leaves 5–6 satellites above 30–35°).
    #[serde(default = "d_mask")]
    pub rover_mask_deg: f64,
    /// The rover loses lock on every satellite at the end of each turn (strip start), with
    /// LLI set and new ambiguities.
    #[serde(default)]
    pub slips_at_turns: bool,
    /// [min, max] seconds: the rover loses lock on every satellite once more at a random
    /// time within that span after each strip start, so each strip starts with a short arc
    /// of its own (a float segment for GNSS alone).
    #[serde(default)]
    pub float_segment_s: Option<[f64; 2]>,
    /// GLONASS inter-channel phase bias of the rover and of the base (in that order), metres
    /// per frequency channel number: both phases of a satellite on channel k carry k·slope
    /// metres. A hook for GLONASS ambiguity-resolution tests, off (0) by default.
    #[serde(default)]
    pub glonass_icb_m_per_channel: [f64; 2],
    /// GLONASS inter-channel code bias of the rover and of the base (in that order), metres
    /// per frequency channel number: both pseudoranges of a satellite on channel k carry
    /// k·slope metres. A hook as the phase one, off (0) by default.
    #[serde(default)]
    pub glonass_code_icb_m_per_channel: [f64; 2],
}

impl Default for ErrorModel {
    fn default() -> Self {
        toml::from_str("").expect("all keys have defaults")
    }
}

impl ErrorModel {
    /// Every error source off (for consistency tests).
    pub fn none() -> Self {
        ErrorModel {
            receiver_clock: false,
            troposphere: false,
            ionosphere: false,
            code_noise: 0.0,
            phase_noise: 0.0,
            multipath: false,
            ambiguities: false,
            cycle_slips: 0,
            gaps: 0,
            image_noise_px: 0.0,
            image_blunders: 0,
            rover_mask_deg: d_mask(),
            slips_at_turns: false,
            float_segment_s: None,
            glonass_icb_m_per_channel: [0.0; 2],
            glonass_code_icb_m_per_channel: [0.0; 2],
        }
    }
}

impl Scenario {
    /// Parse and validate a scenario; errors name the key (or the byte where TOML failed).
    pub fn from_toml(text: &str) -> Result<Scenario, SimError> {
        let s: Scenario = toml::from_str(text).map_err(|e| {
            SimError::Parse(
                e.message().to_string()
                    + &e.span()
                        .map(|r| format!(" (at byte {})", r.start))
                        .unwrap_or_default(),
            )
        })?;
        s.validate()?;
        Ok(s)
    }

    /// The start of the flight as a GPST epoch (years 1999–2099).
    pub fn start_epoch(&self) -> Result<Epoch, SimError> {
        let bad = |what: String| SimError::Key { key: "start", what };
        let p: Vec<&str> = self.start.split(['-', 'T', ':', ' ']).collect();
        let n: Vec<i64> = p
            .iter()
            .map(|x| x.parse::<i64>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad(format!("'{}' is not YYYY-MM-DDTHH:MM:SS", self.start)))?;
        if n.len() != 6 {
            return Err(bad(format!("'{}' is not YYYY-MM-DDTHH:MM:SS", self.start)));
        }
        if !(1999..=2099).contains(&n[0]) {
            return Err(bad(format!(
                "year {} is outside the ephemeris set the simulator can broadcast (1999–2099)",
                n[0]
            )));
        }
        Epoch::maybe_from_gregorian(
            n[0] as i32,
            n[1] as u8,
            n[2] as u8,
            n[3] as u8,
            n[4] as u8,
            n[5] as u8,
            0,
            hifitime::TimeScale::GPST,
        )
        .map_err(|e| bad(format!("'{}' is not a valid date: {e}", self.start)))
    }

    /// Check every value; the first one out of range is returned with its key.
    pub fn validate(&self) -> Result<(), SimError> {
        let f = &self.flight;
        let c = &self.camera;
        let e = &self.errors;
        let checks: [(&'static str, bool, &str); 18] = [
            (
                "flight.speed",
                f.speed > 0.0 && f.speed < 300.0,
                "must be a speed in m/s between 0 and 300",
            ),
            (
                "flight.altitude",
                f.altitude > 0.0 && f.altitude < 10_000.0,
                "must be a height above ground in metres, 0–10 000",
            ),
            (
                "flight.strips",
                (1..=100).contains(&f.strips),
                "must be 1–100",
            ),
            (
                "flight.strip_length",
                f.strip_length > 0.0,
                "must be positive (metres)",
            ),
            (
                "flight.strip_spacing",
                f.strip_spacing > 0.0,
                "must be positive (metres)",
            ),
            (
                "flight.rate_hz",
                f.rate_hz > 0.0 && f.rate_hz <= 20.0,
                "must be 0–20 Hz",
            ),
            (
                "flight.static_start_s",
                f.static_start_s >= 0.0,
                "must not be negative",
            ),
            ("camera.focal_mm", c.focal_mm > 0.0, "must be positive"),
            ("camera.pixel_um", c.pixel_um > 0.0, "must be positive"),
            (
                "camera.width_px",
                c.width_px > 0 && c.height_px > 0,
                "image size must be positive",
            ),
            (
                "camera.forward_overlap",
                (0.0..0.95).contains(&c.forward_overlap),
                "must be 0–0.95",
            ),
            (
                "base.interval_s",
                self.base.interval_s > 0.0 && self.base.interval_s <= 60.0,
                "must be 0–60 s",
            ),
            (
                "site.lat_deg",
                self.site.lat_deg.abs() < 85.0,
                "must be within ±85°",
            ),
            (
                "errors.code_noise",
                e.code_noise >= 0.0,
                "must not be negative",
            ),
            (
                "errors.phase_noise",
                e.phase_noise >= 0.0,
                "must not be negative",
            ),
            (
                "errors.image_noise_px",
                e.image_noise_px >= 0.0,
                "must not be negative",
            ),
            (
                "errors.rover_mask_deg",
                (0.0..=60.0).contains(&e.rover_mask_deg),
                "must be within 0–60 degrees",
            ),
            (
                "errors.float_segment_s",
                e.float_segment_s
                    .is_none_or(|[a, b]| a.is_finite() && b.is_finite() && 0.0 < a && a <= b),
                "must be [min, max] seconds with 0 < min ≤ max",
            ),
        ];
        for (key, ok, what) in checks {
            if !ok {
                return Err(SimError::Key {
                    key,
                    what: what.to_string(),
                });
            }
        }
        self.start_epoch()?;
        self.validate_gnss()
    }

    /// Check the `[gnss]` section and the GLONASS bias hooks.
    fn validate_gnss(&self) -> Result<(), SimError> {
        let sys = &self.gnss.systems;
        if sys.is_empty() || (1..sys.len()).any(|i| sys[..i].contains(&sys[i])) {
            return Err(SimError::Key {
                key: "gnss.systems",
                what: "must name at least one system, each once (\"G\", \"E\", \"R\", \"J\")"
                    .into(),
            });
        }
        let e = &self.errors;
        for (key, v) in [
            (
                "errors.glonass_icb_m_per_channel",
                e.glonass_icb_m_per_channel,
            ),
            (
                "errors.glonass_code_icb_m_per_channel",
                e.glonass_code_icb_m_per_channel,
            ),
        ] {
            if !v.iter().all(|x| x.is_finite() && x.abs() <= 1.0) {
                return Err(SimError::Key {
                    key,
                    what: "must be [rover, base] metres per channel number, within ±1".into(),
                });
            }
        }
        Ok(())
    }

    /// The systems simulated, in `gnss`'s order (GPS, GLONASS, Galileo, QZSS).
    pub fn systems(&self) -> Vec<Constellation> {
        let mut v: Vec<Constellation> = self
            .gnss
            .systems
            .iter()
            .map(|s| s.constellation())
            .collect();
        v.sort();
        v.dedup();
        v
    }

    /// The camera in SI units: metres, with the lever arm.
    pub(crate) fn camera(&self) -> CameraSpec {
        let c = &self.camera;
        CameraSpec {
            focal: c.focal_mm / 1000.0,
            width_px: c.width_px,
            height_px: c.height_px,
            pixel: c.pixel_um * 1e-6,
            lever: photo::lever::LeverArm::new(Vector3::from(c.lever_arm)),
        }
    }

    /// The base antenna in the site's ENU frame, metres.
    pub(crate) fn base_enu(&self) -> Vector3<f64> {
        Vector3::new(
            self.base.east,
            self.base.north,
            self.base.height_above_ground,
        )
    }

    /// The flight plan: strips as the scenario gives them, the aircraft waiting 30 m east of
    /// the base.
    pub(crate) fn plan(&self) -> FlightPlan {
        FlightPlan {
            altitude: self.flight.altitude,
            speed: self.flight.speed,
            strips: self.flight.strips,
            strip_length: self.flight.strip_length,
            strip_spacing: self.flight.strip_spacing,
            heading: self.flight.heading_deg.to_radians(),
            static_start: self.flight.static_start_s,
            start: self.base_enu() + Vector3::new(30.0, 0.0, 0.0),
        }
    }
}
