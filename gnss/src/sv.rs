//! Satellite systems and satellite identifiers.

use std::fmt;

/// A satellite navigation system, with its RINEX letter.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Debug)]
pub enum Constellation {
    /// GPS (G).
    Gps,
    /// GLONASS (R).
    Glonass,
    /// Galileo (E).
    Galileo,
    /// BeiDou (C).
    BeiDou,
    /// QZSS (J).
    Qzss,
    /// SBAS (S).
    Sbas,
    /// NavIC / IRNSS (I).
    Irnss,
}

impl Constellation {
    /// All systems in the order used for clock parameters and reports.
    pub const ALL: [Constellation; 7] = [
        Constellation::Gps,
        Constellation::Galileo,
        Constellation::BeiDou,
        Constellation::Qzss,
        Constellation::Glonass,
        Constellation::Sbas,
        Constellation::Irnss,
    ];

    /// The code-division systems ppkat processes by default, in report order (GLONASS, on
    /// FDMA, is added where inter-frequency biases do not matter).
    pub const CDMA: [Constellation; 4] = [
        Constellation::Gps,
        Constellation::Galileo,
        Constellation::BeiDou,
        Constellation::Qzss,
    ];

    /// From the RINEX system letter (G R E C J S I).
    pub fn from_letter(c: u8) -> Option<Self> {
        Some(match c {
            b'G' | b' ' => Constellation::Gps,
            b'R' => Constellation::Glonass,
            b'E' => Constellation::Galileo,
            b'C' => Constellation::BeiDou,
            b'J' => Constellation::Qzss,
            b'S' => Constellation::Sbas,
            b'I' => Constellation::Irnss,
            _ => return None,
        })
    }

    /// The RINEX system letter.
    pub fn letter(self) -> char {
        match self {
            Constellation::Gps => 'G',
            Constellation::Glonass => 'R',
            Constellation::Galileo => 'E',
            Constellation::BeiDou => 'C',
            Constellation::Qzss => 'J',
            Constellation::Sbas => 'S',
            Constellation::Irnss => 'I',
        }
    }

    /// Index into [`Constellation::ALL`].
    pub fn index(self) -> usize {
        Constellation::ALL
            .iter()
            .position(|&c| c == self)
            .unwrap_or(0)
    }

    /// Parse a comma-separated list of letters such as `G,E,C`.
    pub fn parse_list(s: &str) -> Option<Vec<Constellation>> {
        s.split(',')
            .filter(|t| !t.trim().is_empty())
            .map(|t| {
                let t = t.trim().as_bytes();
                if t.len() == 1 {
                    Constellation::from_letter(t[0].to_ascii_uppercase())
                } else {
                    None
                }
            })
            .collect()
    }
}

/// One satellite: system and PRN (slot number for GLONASS).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Debug)]
pub struct Sv {
    /// System.
    pub sys: Constellation,
    /// PRN (slot number for GLONASS).
    pub prn: u8,
}

impl Sv {
    /// A satellite from its system and PRN.
    pub fn new(sys: Constellation, prn: u8) -> Self {
        Sv { sys, prn }
    }

    /// Parse a three-character RINEX satellite field (`G01`, `G 1`, ` 1` = GPS in RINEX 2).
    pub fn parse(field: &[u8]) -> Option<Sv> {
        if field.len() < 2 {
            return None;
        }
        let (sys, digits) = if field[0].is_ascii_digit() {
            (Constellation::Gps, field)
        } else {
            (Constellation::from_letter(field[0])?, &field[1..])
        };
        let mut prn: u32 = 0;
        let mut any = false;
        for &b in digits {
            match b {
                b'0'..=b'9' => {
                    prn = prn * 10 + (b - b'0') as u32;
                    any = true;
                }
                b' ' => {}
                _ => return None,
            }
        }
        if !any || prn == 0 || prn > 255 {
            return None;
        }
        Some(Sv::new(sys, prn as u8))
    }
}

impl fmt::Display for Sv {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{:02}", self.sys.letter(), self.prn)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn parses_satellite_fields() {
        assert_eq!(Sv::parse(b"G01"), Some(Sv::new(Constellation::Gps, 1)));
        assert_eq!(Sv::parse(b"R 7"), Some(Sv::new(Constellation::Glonass, 7)));
        assert_eq!(Sv::parse(b"12"), Some(Sv::new(Constellation::Gps, 12)));
        assert_eq!(Sv::parse(b"X01"), None);
        assert_eq!(Sv::parse(b"G00"), None);
        assert_eq!(Sv::new(Constellation::BeiDou, 5).to_string(), "C05");
        assert_eq!(
            Constellation::parse_list("G, e,C"),
            Some(vec![
                Constellation::Gps,
                Constellation::Galileo,
                Constellation::BeiDou
            ])
        );
        assert_eq!(Constellation::parse_list("G,X"), None);
    }
}
