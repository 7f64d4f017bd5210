//! The built-in flight scenarios: `demo`, `block20`, `long`, `hard-sky` — the `demo` scenario as TOML,
//! the others derived from it with more and longer strips. Leaves: a [`Scenario`].

use super::scenario::Scenario;

const DEMO: &str = r#"
name = "demo"
seed = 7
start = "2024-06-12T09:00:00"
[site]
lat_deg = 47.30
lon_deg = 8.55
ground_height = 480.0
[flight]
altitude = 350.0
speed = 55.0
strips = 3
strip_length = 2500.0
strip_spacing = 160.0
heading_deg = 20.0
rate_hz = 10.0
static_start_s = 60.0
[camera]
focal_mm = 35.0
width_px = 4000
height_px = 6000
pixel_um = 3.9
forward_overlap = 0.8
lever_arm = [0.10, -0.05, 0.45]
[base]
east = 300.0
north = -2500.0
height_above_ground = 2.0
interval_s = 1.0
[ground]
gcps = 5
checks = 6
ties = 1500
relief = 15.0
"#;

/// A built-in scenario by name: `demo` (about 4 minutes), `block20` (20 minutes, 10 Hz),
/// `long` (one hour, 10 Hz, for benchmarks) or `hard-sky` (5 strips where GNSS alone stays
/// float at every strip start: see `integration::hard_sky`).
pub fn builtin(name: &str) -> Option<Scenario> {
    let mut s: Scenario = toml::from_str(DEMO).ok()?;
    match name {
        "demo" => {}
        "block20" => {
            s.name = "block20".into();
            s.flight.strips = 8;
            s.flight.strip_length = 7500.0;
        }
        "long" => {
            s.name = "long".into();
            s.flight.strips = 21;
            s.flight.strip_length = 9000.0;
        }
        "hard-sky" => {
            // GNSS alone fails here: 5–6 satellites, every one lost at each turn and again
            // 30–60 s into each strip, a base 20 km away.
            s.name = "hard-sky".into();
            s.seed = 21;
            s.flight.strips = 4;
            s.flight.strip_length = 7000.0;
            s.base.east = 3000.0;
            s.base.north = -19800.0;
            s.ground.ties = 1500;
            s.errors.rover_mask_deg = 20.0;
            s.errors.slips_at_turns = true;
            s.errors.float_segment_s = Some([30.0, 60.0]);
        }
        _ => return None,
    }
    Some(s)
}

/// Names of the built-in flight scenarios.
pub const BUILTINS: [&str; 4] = ["demo", "block20", "long", "hard-sky"];
