//! The camera of a photograph from its metadata: the focal length in pixels from DJI's
//! calibrated focal length, else EXIF focal length × focal-plane resolution, else focal length
//! × a built-in sensor width of common drone cameras, else the 35 mm equivalent (over the
//! diagonal); the principal point from DJI's optical centre, else the image centre. Photos
//! share a camera when model, size and focal length agree.

use super::meta::PhotoMeta;
use photo::camera::Camera;

/// Sensor widths (mm) of common drone cameras by EXIF model (the long side of the sensor
/// used by the photo modes of the table's image widths).
const SENSORS: [(&str, f64); 12] = [
    ("FC300S", 6.317),   // Phantom 3 Professional
    ("FC300X", 6.317),   // Phantom 3 Advanced
    ("FC330", 6.317),    // Phantom 4
    ("FC220", 6.17),     // Mavic Pro
    ("FC6310", 13.2),    // Phantom 4 Pro
    ("FC6310S", 13.2),   // Phantom 4 Pro V2
    ("FC6310R", 13.2),   // Phantom 4 RTK
    ("FC6510", 13.2),    // Zenmuse X4S
    ("FC6520", 17.3),    // Zenmuse X5S
    ("L1D-20C", 13.2),   // Mavic 2 Pro
    ("M3E", 17.3),       // Mavic 3 Enterprise
    ("ZENMUSEP1", 35.9), // Zenmuse P1
];

/// A camera and how it was found.
#[derive(Clone, Debug)]
pub struct FoundCamera {
    /// The camera (pixel size from the sensor when known, else nominal).
    pub camera: Camera,
    /// A short id: the model without spaces, with the size.
    pub key: String,
    /// Where the focal length came from.
    pub source: &'static str,
}

fn sensor_width(model: &str) -> Option<f64> {
    let m = model.to_ascii_uppercase().replace([' ', '-'], "");
    SENSORS
        .iter()
        .find(|(k, _)| m.ends_with(&k.replace('-', "")))
        .map(|x| x.1)
}

/// The camera of `m` for a photograph of `w × h` pixels; `Err(reason)` when the metadata give
/// no focal length.
pub fn from_meta(m: &PhotoMeta, w: u32, h: u32) -> Result<FoundCamera, String> {
    let (wf, hf) = (w as f64, h as f64);
    let sensor = sensor_width(&m.model);
    let (f_px, source) = if let Some(f) = m.dji.calibrated_focal_px.filter(|f| *f > 0.0) {
        (f, "DJI calibrated focal length")
    } else if let (Some(f), Some(r)) = (m.focal_mm, m.focal_plane_px_per_mm) {
        (f * r, "EXIF focal length and focal-plane resolution")
    } else if let (Some(f), Some(s)) = (m.focal_mm, sensor) {
        (f * wf.max(hf) / s, "EXIF focal length and the sensor table")
    } else if let Some(f35) = m.focal_35mm {
        (
            f35 * wf.hypot(hf) / 36f64.hypot(24.0),
            "EXIF 35 mm equivalent focal length",
        )
    } else {
        return Err("its EXIF gives no focal length: give --camera FILE.toml".into());
    };
    if !(f_px.is_finite() && f_px > 1.0) {
        return Err(format!(
            "its focal length ({f_px} px) is not usable: give --camera FILE.toml"
        ));
    }
    // Pixel size: from the focal length in mm when known, else a nominal 1 µm.
    let pixel = m.focal_mm.map_or(1e-6, |f| f * 1e-3 / f_px);
    let mut camera = Camera::ideal(f_px * pixel, pixel, w as usize, h as usize);
    if let Some([cx, cy]) = m.dji.optical_centre_px {
        let p = camera.pixel_to_image(nalgebra::Vector2::new(cx, cy));
        camera.x0 = p.x;
        camera.y0 = p.y;
    }
    let model: String = m
        .model
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    Ok(FoundCamera {
        camera,
        key: format!("{model}_{w}x{h}_{:.0}", f_px),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::meta::DjiXmp;

    fn meta() -> PhotoMeta {
        PhotoMeta {
            path: "x.jpg".into(),
            id: "x".into(),
            model: "DJI FC300S".into(),
            size: Some((4000, 2250)),
            focal_mm: Some(3.61),
            focal_35mm: Some(20.0),
            focal_plane_px_per_mm: None,
            gps: None,
            taken: None,
            dji: DjiXmp::default(),
        }
    }

    #[test]
    fn focal_length_sources_in_order() {
        let c = from_meta(&meta(), 4000, 2250).unwrap();
        assert!(
            (c.camera.f / c.camera.pixel - 2285.9).abs() < 0.5,
            "{}",
            c.camera.f / c.camera.pixel
        );
        assert_eq!(c.source, "EXIF focal length and the sensor table");
        let mut m = meta();
        m.model = "Acme".into();
        let c = from_meta(&m, 4000, 2250).unwrap();
        assert!((c.camera.f / c.camera.pixel - 20.0 * 4589.1 / 43.267).abs() < 1.0);
        m.dji.calibrated_focal_px = Some(3666.0);
        m.dji.optical_centre_px = Some([2010.0, 1120.0]);
        let c = from_meta(&m, 4000, 2250).unwrap();
        assert!((c.camera.f / c.camera.pixel - 3666.0).abs() < 1e-9);
        let pp = c
            .camera
            .image_to_pixel(nalgebra::Vector2::new(c.camera.x0, c.camera.y0));
        assert!((pp.x - 2010.0).abs() < 1e-9 && (pp.y - 1120.0).abs() < 1e-9);
        m.focal_35mm = None;
        m.dji = DjiXmp::default();
        assert!(from_meta(&m, 4000, 2250).unwrap_err().contains("--camera"));
    }
}
