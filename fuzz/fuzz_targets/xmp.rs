#![no_main]
//! XMP packets: the DJI fields `match` scans for, and the geotag writer's editing of a
//! photo's packet, on the text alone and inside a JPEG's APP1 segment.

use libfuzzer_sys::fuzz_target;

/// A 16 × 16 JPEG to carry the packet.
const JPEG: &[u8] = include_bytes!("../../fixtures/photo_16x16.jpg");
/// The XMP APP1 identifier.
const XMP_ID: &[u8] = b"http://ns.adobe.com/xap/1.0/\0";

fuzz_target!(|data: &[u8]| {
    use integration::exposure::{exif_io, xmp};
    let text = String::from_utf8_lossy(data);
    let _ = integration::tiepoints::meta::dji_xmp(&text);
    let tag = xmp::PositionTag {
        lat: 47.3,
        lon: 8.5,
        height: 830.0,
        reference: "ellipsoidal (WGS84)".into(),
        orthometric: false,
        sigma_enu: [0.01, 0.01, 0.02],
        quality: 1,
    };
    let edited = xmp::packet(Some(&text), &tag);
    let _ = xmp::value(&edited, "ppkat:Height");
    let _ = xmp::value(&text, "drone-dji:GpsLatitude");
    // The packet in a JPEG after SOI, when it fits a segment.
    if data.len() + XMP_ID.len() + 2 <= 0xFFFF {
        let len = (data.len() + XMP_ID.len() + 2) as u16;
        let mut jpeg = JPEG[..2].to_vec();
        jpeg.extend_from_slice(&[0xFF, 0xE1]);
        jpeg.extend_from_slice(&len.to_be_bytes());
        jpeg.extend_from_slice(XMP_ID);
        jpeg.extend_from_slice(data);
        jpeg.extend_from_slice(&JPEG[2..]);
        let _ = exif_io::xmp_packet(&jpeg);
        if let Ok(copy) = exif_io::geotagged(&jpeg, &tag) {
            let _ = exif_io::xmp_packet(&copy);
        }
    }
});
