//! Geotagged copies read back as other tools read them: the EXIF with kamadak-exif, the XMP
//! packet parsed as XML. The height and its reference are the ones meant, within 1 cm; a DJI
//! photo's own position, altitude and RTK tags are replaced, not left stale.

use integration::exposure::exif_io;
use integration::exposure::xmp::{self, PositionTag};
use std::path::PathBuf;

fn tag(orthometric: bool) -> PositionTag {
    PositionTag {
        lat: 46.8427123,
        lon: -92.0654321,
        height: if orthometric { 213.4567 } else { 184.1234 },
        reference: if orthometric {
            "orthometric heights H = h - N, EGM96 geoid".into()
        } else {
            "ellipsoidal heights (WGS84)".into()
        },
        orthometric,
        sigma_enu: [0.012, 0.016, 0.031],
        quality: 1,
    }
}

/// The attributes of the packet's `rdf:Description`, parsed as XML (so the packet is
/// well-formed), by qualified name.
fn description(packet: &str) -> Vec<(String, String)> {
    let body = &packet[packet.find("<x:xmpmeta").unwrap()..packet.find("<?xpacket end").unwrap()];
    let doc = roxmltree::Document::parse(body).expect("well-formed XMP");
    let d = doc
        .descendants()
        .find(|n| n.tag_name().name() == "Description")
        .unwrap();
    d.attributes()
        .map(|a| {
            let prefix = d.lookup_prefix(a.namespace().unwrap_or("")).unwrap_or("");
            (format!("{prefix}:{}", a.name()), a.value().to_string())
        })
        .collect()
}

fn get<'a>(attrs: &'a [(String, String)], name: &str) -> Option<&'a str> {
    attrs
        .iter()
        .find(|(k, _)| k == name)
        .map(|(_, v)| v.as_str())
}

fn check_copy(original: &[u8], dji: bool) {
    for orthometric in [true, false] {
        let t = tag(orthometric);
        let copy = exif_io::geotagged(original, &t).unwrap();
        let x = exif::Reader::new()
            .read_from_container(&mut std::io::Cursor::new(&copy))
            .unwrap();
        let (lat, lon, h) = exif_io::gps_position(&x).unwrap();
        assert!((lat - t.lat).abs() < 1e-7 && (lon - t.lon).abs() < 1e-7);
        if orthometric {
            // Sea level claimed only for a geoid height: ref 0 (above), the height to 1 cm.
            let r = x
                .get_field(exif::Tag::GPSAltitudeRef, exif::In::PRIMARY)
                .unwrap();
            assert_eq!(r.value.get_uint(0), Some(0));
            assert!((h.unwrap() - t.height).abs() < 0.01, "{h:?}");
        } else {
            assert!(
                h.is_none(),
                "an ellipsoidal height is not written as sea level"
            );
        }
        let packet = exif_io::xmp_packet(&copy).expect("an XMP packet");
        let a = description(&packet);
        let num = |k: &str| -> f64 { get(&a, k).unwrap_or_else(|| panic!("{k}")).parse().unwrap() };
        assert!((num("ppkat:Height") - t.height).abs() < 0.01);
        assert_eq!(get(&a, "ppkat:HeightReference"), Some(t.reference.as_str()));
        assert!((num("Camera:GPSXYAccuracy") - 0.02).abs() < 1e-4);
        assert!((num("Camera:GPSZAccuracy") - 0.031).abs() < 1e-4);
        if dji {
            assert!((num("drone-dji:AbsoluteAltitude") - t.height).abs() < 0.01);
            assert!((num("drone-dji:GpsLatitude") - t.lat).abs() < 1e-7);
            assert!((num("drone-dji:RtkStdHgt") - 0.031).abs() < 1e-4);
            assert_eq!(get(&a, "drone-dji:RtkFlag"), Some("50"));
            assert_eq!(packet.matches("drone-dji:AbsoluteAltitude").count(), 1);
        }
        // Tagging the copy again replaces, never duplicates.
        let again = exif_io::geotagged(&copy, &t).unwrap();
        let p2 = exif_io::xmp_packet(&again).unwrap();
        assert_eq!(p2.matches("ppkat:Height=").count(), 1);
        assert_eq!(
            xmp::value(&p2, "ppkat:Height"),
            xmp::value(&packet, "ppkat:Height")
        );
    }
}

/// A photo without XMP gets a packet of its own.
#[test]
fn plain_jpeg_gets_an_xmp_packet() {
    let f = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/photo_16x16.jpg");
    let original = std::fs::read(&f).unwrap();
    check_copy(&original, false);
    assert_eq!(std::fs::read(&f).unwrap(), original, "original untouched");
}

/// A real DJI photo (Phantom 3, `drone-dji` XMP): its tags are replaced.
#[test]
fn dji_photo_tags_are_replaced() {
    let Some(f) = testkit::shared_data("photo/brighton-beach/DJI_0018.JPG") else {
        return;
    };
    let original = std::fs::read(&f).unwrap();
    let old = exif_io::xmp_packet(&original).expect("DJI photos carry XMP");
    assert!(old.contains("drone-dji:AbsoluteAltitude"));
    check_copy(&original, true);
    assert_eq!(std::fs::read(&f).unwrap(), original, "original untouched");
}
