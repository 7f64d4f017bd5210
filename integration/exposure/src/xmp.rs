//! The XMP packet of a geotagged copy: the height written and what it is measured from, the
//! accuracies photogrammetry software reads (Pix4D's `Camera:GPSXYAccuracy`,
//! `Camera:GPSZAccuracy`), and for DJI photos the `drone-dji` position, altitude and RTK tags
//! replaced so no stale value of the drone contradicts the new position.
//!
//! Enters: the photo's packet (text of its XMP APP1 segment), when it has one, and a
//! [`PositionTag`]. Leaves: a well-formed packet. Edits are made on the first
//! `rdf:Description` start tag (attributes) or on existing elements of the same name, by
//! bounded string searches; values are numbers or escaped text.

/// The APP1 identifier of an XMP segment.
pub const XMP_ID: &[u8] = b"http://ns.adobe.com/xap/1.0/\0";
/// Pix4D's camera namespace.
const CAMERA_NS: &str = "http://pix4d.com/camera/1.0/";
/// ppkat's namespace for what no other namespace says (the height and its reference).
const PPKAT_NS: &str = "https://ppkat.invalid/xmp/1.0/";

/// What a geotagged copy carries.
#[derive(Clone, Debug)]
pub struct PositionTag {
    /// WGS84 latitude, longitude (degrees).
    pub lat: f64,
    /// WGS84 longitude (degrees).
    pub lon: f64,
    /// The height written (m): ellipsoidal or orthometric, as `reference` says.
    pub height: f64,
    /// What the height is measured from, e.g. `ellipsoidal (WGS84)` or `EGM96 geoid`.
    pub reference: String,
    /// Whether `height` is above a geoid (sea level): only then does the EXIF GPSAltitude
    /// carry it.
    pub orthometric: bool,
    /// σ east, north, up of the position (m).
    pub sigma_enu: [f64; 3],
    /// RTKLIB's Q of the position (1 fixed, 2 float, 5 single).
    pub quality: u8,
}

impl PositionTag {
    /// DJI's RtkFlag for the quality: 50 fixed, 34 float, 16 single point, 0 none.
    fn dji_rtk_flag(&self) -> u8 {
        match self.quality {
            1 => 50,
            2 => 34,
            4..=6 => 16,
            _ => 0,
        }
    }

    /// The (qualified name, value) pairs written.
    fn fields(&self, dji: bool) -> Vec<(&'static str, String)> {
        let [se, sn, su] = self.sigma_enu;
        let mut v = vec![
            ("Camera:GPSXYAccuracy", format!("{:.4}", se.hypot(sn))),
            ("Camera:GPSZAccuracy", format!("{su:.4}")),
            ("ppkat:Height", format!("{:.4}", self.height)),
            ("ppkat:HeightReference", escape(&self.reference)),
        ];
        if dji {
            v.extend([
                ("drone-dji:GpsLatitude", format!("{:.9}", self.lat)),
                ("drone-dji:GpsLongitude", format!("{:.9}", self.lon)),
                ("drone-dji:GpsLongtitude", format!("{:.9}", self.lon)),
                ("drone-dji:AbsoluteAltitude", format!("{:+.4}", self.height)),
                ("drone-dji:RtkStdLon", format!("{se:.4}")),
                ("drone-dji:RtkStdLat", format!("{sn:.4}")),
                ("drone-dji:RtkStdHgt", format!("{su:.4}")),
                ("drone-dji:RtkFlag", self.dji_rtk_flag().to_string()),
            ]);
        }
        v
    }
}

/// Text safe in an XML attribute.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('"', "&quot;")
}

/// A minimal packet when the photo has none.
fn empty_packet() -> String {
    "<?xpacket begin=\"\u{feff}\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\n<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\"><rdf:Description rdf:about=\"\"/></rdf:RDF></x:xmpmeta>\n<?xpacket end=\"w\"?>".into()
}

/// The byte range of the first `rdf:Description` start tag (from `<` to its `>`), quotes
/// respected.
fn description_tag(p: &str) -> Option<(usize, usize)> {
    let start = p.find("<rdf:Description")?;
    let mut quote = None;
    for (k, c) in p[start..].char_indices() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '>') => return Some((start, start + k)),
            _ => {}
        }
    }
    None
}

/// Set attribute `name` on the Description tag, or the text of an element `<name>` where the
/// packet has one.
fn set(p: &mut String, name: &str, value: &str) -> Option<()> {
    let open = format!("<{name}>");
    if let Some(a) = p.find(&open) {
        let from = a + open.len();
        let b = from + p[from..].find(&format!("</{name}>"))?;
        p.replace_range(from..b, value);
        return Some(());
    }
    let (s, e) = description_tag(p)?;
    let key = format!(" {name}=\"");
    if let Some(k) = p[s..e].find(&key) {
        let from = s + k + key.len();
        let b = from + p[from..e].find('"')?;
        p.replace_range(from..b, value);
    } else if !name.starts_with("drone-dji:GpsLong") {
        let at = if p[..e].ends_with('/') { e - 1 } else { e };
        p.insert_str(at, &format!("\n   {name}=\"{value}\""));
    }
    Some(())
}

/// Declare `prefix` on the Description tag unless the packet already does.
fn declare(p: &mut String, prefix: &str, uri: &str) -> Option<()> {
    if p.contains(&format!("xmlns:{prefix}=")) {
        return Some(());
    }
    let (s, _) = description_tag(p)?;
    let at = s + "<rdf:Description".len();
    p.insert_str(at, &format!(" xmlns:{prefix}=\"{uri}\""));
    Some(())
}

/// The packet of a geotagged copy: `old` (the photo's packet, if any) with `tag`'s fields set.
/// `None` when `old` has no `rdf:Description` to carry them (the caller then starts afresh).
pub fn packet(old: Option<&str>, tag: &PositionTag) -> String {
    edit(old.unwrap_or(""), tag)
        .unwrap_or_else(|| edit(&empty_packet(), tag).expect("the empty packet has a Description"))
}

fn edit(old: &str, tag: &PositionTag) -> Option<String> {
    let mut p = old.to_string();
    description_tag(&p)?;
    declare(&mut p, "Camera", CAMERA_NS)?;
    declare(&mut p, "ppkat", PPKAT_NS)?;
    let dji = p.contains("xmlns:drone-dji=");
    for (name, value) in tag.fields(dji) {
        // DJI spells it GpsLongtitude in some firmware: only an existing one is replaced.
        if name.starts_with("drone-dji:GpsLong") && !p.contains(name) {
            continue;
        }
        set(&mut p, name, &value)?;
    }
    Some(p)
}

/// The text value of `name` in a packet (attribute or element), for reading copies back.
pub fn value<'a>(p: &'a str, name: &str) -> Option<&'a str> {
    let key = format!("{name}=\"");
    if let Some(k) = p.find(&key) {
        let from = k + key.len();
        return Some(&p[from..from + p[from..].find('"')?]);
    }
    let open = format!("<{name}>");
    let from = p.find(&open)? + open.len();
    Some(&p[from..from + p[from..].find('<')?])
}
