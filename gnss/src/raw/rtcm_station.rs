//! What an RTCM 3 log says of its reference station: the antenna reference point (1005,
//! 1006 with the antenna height), the antenna descriptor and serial number (1007, 1008, 1033)
//! and the receiver (1033).
//!
//! What enters: message payloads. What leaves: their fields gathered in a [`Station`] (the
//! last message of each kind wins), or `Err` for a payload shorter than it announces.
//! Positions are ECEF in 0.0001 m (38-bit two's complement, DF025–DF027), the antenna height
//! in 0.0001 m (16 bits, DF028); strings are counted (8-bit count, then that many bytes,
//! DF029–DF033, DF227–DF231), printable ASCII kept.

use super::bits::{bits_s, bits_u};
use super::rtcm::message_number;
use crate::frame::{Ecef, Enu};
use nalgebra::Vector3;
use std::fmt;

/// A reference station as its log describes it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Station {
    /// Reference station id (DF003).
    pub id: Option<u16>,
    /// Antenna reference point, ECEF metres (1005/1006).
    pub arp: Option<[f64; 3]>,
    /// Antenna height: the ARP above the marker, metres (1006).
    pub height: Option<f64>,
    /// Antenna descriptor (IGS name with radome, as ANTEX and RINEX have it; 1007/1008/1033).
    pub antenna: Option<String>,
    /// Antenna setup id (0: use the standard IGS model).
    pub antenna_setup: u8,
    /// Antenna serial number (1008/1033).
    pub antenna_serial: Option<String>,
    /// Receiver type descriptor (1033).
    pub receiver: Option<String>,
    /// Receiver firmware version (1033).
    pub firmware: Option<String>,
    /// Receiver serial number (1033).
    pub receiver_serial: Option<String>,
}

impl Station {
    /// The marker: the ARP lowered by the antenna height along the local vertical (the ARP
    /// itself without a height).
    pub fn marker(&self) -> Option<Ecef> {
        let [x, y, z] = self.arp?;
        let arp = Ecef::new(x, y, z);
        Some(Enu(Vector3::new(0.0, 0.0, -self.height.unwrap_or(0.0))).to_ecef(&arp))
    }

    /// The station as a RINEX header carries it: strings cut to their 20 columns,
    /// coordinates and height to 0.1 mm (as written and read back).
    pub fn rinex(&self) -> RinexStation {
        let cut = |s: &Option<String>| {
            let s = s.as_deref().unwrap_or("");
            s.chars().take(20).collect::<String>().trim().to_string()
        };
        let mm = |v: f64| (v * 1e4).round() / 1e4;
        RinexStation {
            approx: self.marker().map(|m| [mm(m.0.x), mm(m.0.y), mm(m.0.z)]),
            height: mm(self.height.unwrap_or(0.0)),
            antenna: [cut(&self.antenna_serial), cut(&self.antenna)],
            receiver: [
                cut(&self.receiver_serial),
                cut(&self.receiver),
                cut(&self.firmware),
            ],
        }
    }

    /// Whether any message described the station.
    pub fn is_known(&self) -> bool {
        self.arp.is_some() || self.antenna.is_some() || self.receiver.is_some()
    }

    /// Take a 1005/1006/1007/1008/1033 payload; `false` when it is shorter than its fields
    /// (what it held before it ran out may have been taken).
    pub fn add(&mut self, p: &[u8]) -> bool {
        match message_number(p) {
            1005 | 1006 => self.position(p).is_ok(),
            1007 | 1008 | 1033 => self.descriptors(p).is_ok(),
            _ => true,
        }
    }

    fn position(&mut self, p: &[u8]) -> Result<(), ()> {
        let h = message_number(p) == 1006;
        if p.len() * 8 < if h { 168 } else { 152 } {
            return Err(());
        }
        self.id = Some(bits_u(p, 12, 12) as u16);
        self.arp = Some([f38(p, 34), f38(p, 74), f38(p, 114)]);
        self.height = h.then(|| bits_u(p, 152, 16) as f64 * 1e-4);
        Ok(())
    }

    fn descriptors(&mut self, p: &[u8]) -> Result<(), ()> {
        let msg = message_number(p);
        let mut r = Strings { p, pos: 24 };
        self.id = Some(bits_u(p, 12, 12) as u16);
        self.antenna = Some(r.string()?);
        self.antenna_setup = r.byte()?;
        if msg == 1007 {
            return Ok(());
        }
        self.antenna_serial = Some(r.string()?);
        if msg == 1033 {
            self.receiver = Some(r.string()?);
            self.firmware = Some(r.string()?);
            self.receiver_serial = Some(r.string()?);
        }
        Ok(())
    }
}

/// The station fields of a RINEX observation header.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RinexStation {
    /// APPROX POSITION XYZ: the marker, metres.
    pub approx: Option<[f64; 3]>,
    /// ANTENNA: DELTA H, metres.
    pub height: f64,
    /// ANT # / TYPE: serial number, type.
    pub antenna: [String; 2],
    /// REC # / TYPE / VERS: serial number, type, version.
    pub receiver: [String; 3],
}

/// A 38-bit two's-complement field of 0.0001 m at bit `pos`, in metres.
fn f38(p: &[u8], pos: usize) -> f64 {
    (bits_s(p, pos, 6) as i64 * (1 << 32) + bits_u(p, pos + 6, 32) as i64) as f64 * 1e-4
}

/// Counted strings read in order.
struct Strings<'a> {
    p: &'a [u8],
    pos: usize,
}

impl Strings<'_> {
    fn byte(&mut self) -> Result<u8, ()> {
        if self.pos + 8 > self.p.len() * 8 {
            return Err(());
        }
        let b = bits_u(self.p, self.pos, 8) as u8;
        self.pos += 8;
        Ok(b)
    }
    fn string(&mut self) -> Result<String, ()> {
        let n = self.byte()?;
        let mut s = String::with_capacity(n as usize);
        for _ in 0..n {
            let c = self.byte()?;
            s.push(if (0x20..0x7f).contains(&c) {
                c as char
            } else {
                '?'
            });
        }
        Ok(s.trim_end().to_string())
    }
}

impl fmt::Display for Station {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some([x, y, z]) = self.arp {
            write!(
                f,
                "station ARP (RTCM 1005/1006): ECEF {x:.4} {y:.4} {z:.4} m"
            )?;
            if let Some(h) = self.height {
                write!(f, ", antenna height {h:.4} m")?;
            }
            writeln!(f)?;
        }
        let opt = |s: &Option<String>| s.clone().unwrap_or_default();
        if let Some(a) = &self.antenna {
            writeln!(
                f,
                "antenna (RTCM 1007/1008/1033): '{a}' setup {} serial '{}'",
                self.antenna_setup,
                opt(&self.antenna_serial)
            )?;
        }
        if let Some(r) = &self.receiver {
            writeln!(
                f,
                "receiver (RTCM 1033): '{r}' firmware '{}' serial '{}'",
                opt(&self.firmware),
                opt(&self.receiver_serial)
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::bits::set_bits;

    #[test]
    fn negative_38_bit_coordinates() {
        // -1 m = -10000 units: 38 bits of two's complement
        let mut p = [0u8; 21];
        set_bits(&mut p, 0, 12, 1006);
        let v = (-10_000i64) & ((1 << 38) - 1);
        set_bits(&mut p, 34, 6, (v >> 32) as u32);
        set_bits(&mut p, 40, 32, v as u32);
        set_bits(&mut p, 152, 16, 15_000);
        let mut s = Station::default();
        assert!(s.add(&p));
        assert_eq!(s.arp.unwrap()[0], -1.0);
        assert_eq!(s.height, Some(1.5));
        assert!(!s.add(&p[..20]));
    }

    #[test]
    fn descriptors_of_1033() {
        let mut p = vec![0x40, 0x90, 0x07]; // 1033, station 7
        for s in ["TRM59800.00     NONE", "5000"] {
            p.push(s.len() as u8);
            p.extend(s.bytes());
            if s.starts_with("TRM") {
                p.push(0); // setup
            }
        }
        for s in ["SEPT POLARX5", "5.4.0", "3001"] {
            p.push(s.len() as u8);
            p.extend(s.bytes());
        }
        let mut st = Station::default();
        assert!(st.add(&p));
        assert_eq!(st.id, Some(7));
        assert_eq!(st.antenna.as_deref(), Some("TRM59800.00     NONE"));
        assert_eq!(st.receiver.as_deref(), Some("SEPT POLARX5"));
        assert_eq!(st.receiver_serial.as_deref(), Some("3001"));
        assert!(!st.add(&p[..p.len() - 2]));
    }
}
