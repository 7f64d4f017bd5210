//! SBF MeasEpoch (block 4027, revision 0 and later) decoded into its Type-1 and Type-2
//! sub-blocks in physical units.
//!
//! What enters: one whole MeasEpoch block with a valid CRC ([`super::sbf`] cuts them). What
//! leaves: a [`MeasEpoch`] whose satellites hold their master (Type-1) signal and the Type-2
//! signals after it, every do-not-use value as `None`; or `None` when the block's sub-block
//! lengths or counts do not fit it. Values become RINEX observations in [`super::sbf_obs`].
//!
//! Layout (offsets from the sync): TOW 8, WNc 12, N1 14, SB1Length 15, SB2Length 16,
//! CommonFlags 17, CumClkJumps 18, reserved 19, then N1 Type-1 sub-blocks of SB1Length bytes
//! (≥ 20: RxChannel, Type, SVID, Misc with CodeMSB, CodeLSB u4, Doppler i4 0.0001 Hz,
//! CarrierLSB u2, CarrierMSB i1, CN0, LockTime u2 s, ObsInfo, N2), each followed by its N2
//! Type-2 sub-blocks of SB2Length bytes (≥ 12: Type, LockTime u1, CN0, OffsetsMSB (code 3
//! bits, Doppler 5 bits), CarrierMSB, ObsInfo, CodeOffsetLSB, CarrierLSB, DopplerOffsetLSB).
//! Pseudorange = CodeMSB·4294967.296 + CodeLSB·0.001 m (both 0: do not use); a Type-2
//! pseudorange is the master's plus CodeOffsetMSB·65.536 + CodeOffsetLSB·0.001 (−4, 0: do not
//! use); the carrier field is (MSB·65536 + LSB)·0.001 cycles (−128, 0: do not use); a Type-2
//! Doppler offset is MSB·6.5536 + LSB·0.0001 Hz (−16, 0: do not use); C/N0 0.25 dB-Hz + 10
//! except GPS L1P/L2P (255: do not use). Sub-blocks start at 20 in every revision (RTKLIB
//! reads them there too).

use super::sbf::{time_tag, Le};

/// One signal of a MeasEpoch, as the block carries it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigMeas {
    /// SBF signal number (0..=63: the type field's low 5 bits, or 32 + ObsInfo bits 3–7
    /// when they are 31).
    pub sig: u8,
    /// Antenna (0 main, 1 Aux1, 2 Aux2).
    pub antenna: u8,
    /// Pseudorange, m (`None`: do not use).
    pub pr: Option<f64>,
    /// Carrier phase minus pseudorange over wavelength, cycles (`None`: do not use).
    pub carrier: Option<f64>,
    /// Doppler, Hz; in a Type-2 sub-block the offset from the master's Doppler scaled to this
    /// signal's frequency (`None`: do not use).
    pub doppler: Option<f64>,
    /// C/N0, dB-Hz (`None`: do not use).
    pub cn0: Option<f64>,
    /// Lock time, s (clipped by the receiver at 65534 in Type-1, 254 in Type-2; `None`: do
    /// not use).
    pub lock: Option<u16>,
    /// ObsInfo bit 2: the phase has a half-cycle ambiguity.
    pub half: bool,
    /// From a Type-2 sub-block (offsets from the Type-1 master).
    pub type2: bool,
}

/// One satellite of a MeasEpoch: its Type-1 sub-block and the Type-2 ones after it.
#[derive(Clone, Debug, PartialEq)]
pub struct SatMeas {
    /// SBF SVID.
    pub svid: u8,
    /// GLONASS frequency number (−7..=6) when the master signal is a GLONASS FDMA one.
    pub fcn: Option<i8>,
    /// The Type-1 signal first, then the Type-2 ones.
    pub sigs: Vec<SigMeas>,
}

/// A decoded MeasEpoch block.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasEpoch {
    /// Receiver time of week, ms (`None`: do not use).
    pub tow_ms: Option<u32>,
    /// GPS week (`None`: do not use).
    pub wnc: Option<u16>,
    /// CommonFlags (bit 7: measurements scrambled).
    pub flags: u8,
    /// Satellites in block order.
    pub sats: Vec<SatMeas>,
}

/// C/N0 in dB-Hz of a raw value: 0.25 dB-Hz steps, plus 10 dB-Hz except for GPS L1P and L2P
/// (signal numbers 1 and 2); 255 is do-not-use.
pub fn cn0(raw: u8, sig: u8) -> Option<f64> {
    (raw != 255).then_some(raw as f64 * 0.25 + if sig == 1 || sig == 2 { 0.0 } else { 10.0 })
}

/// The signal number of a type field and ObsInfo byte.
fn signal_number(typ: u8, info: u8) -> u8 {
    match typ & 0x1f {
        31 => 32 + (info >> 3),
        s => s,
    }
}

/// A two's-complement field of `n` bits in the low bits of `v`.
fn signed(v: u8, n: u32) -> i32 {
    let v = v as i32 & ((1 << n) - 1);
    if v >> (n - 1) & 1 == 1 {
        v - (1 << n)
    } else {
        v
    }
}

/// The Type-1 sub-block at `o`: the satellite and its master signal, and its Type-2 count.
fn type1(f: &Le, o: usize) -> (SatMeas, usize) {
    let typ = f.u8(o + 1);
    let info = f.u8(o + 18);
    let sig = signal_number(typ, info);
    let code_msb = f.u8(o + 3) & 0x0f;
    let code_lsb = f.u32(o + 4);
    let doppler = f.i32(o + 8);
    let (c_lsb, c_msb) = (f.u16(o + 12), f.i8(o + 14));
    let lock = f.u16(o + 16);
    let m = SigMeas {
        sig,
        antenna: typ >> 5,
        pr: (code_msb != 0 || code_lsb != 0)
            .then_some(code_msb as f64 * 4_294_967.296 + code_lsb as f64 * 0.001),
        carrier: (c_msb != -128 || c_lsb != 0)
            .then(|| (c_msb as i32 * 65536 + c_lsb as i32) as f64 * 0.001),
        doppler: (doppler != i32::MIN).then_some(doppler as f64 * 1e-4),
        cn0: cn0(f.u8(o + 15), sig),
        lock: (lock != u16::MAX).then_some(lock),
        half: info & 4 != 0,
        type2: false,
    };
    let fcn = (8..=11)
        .contains(&(typ & 0x1f))
        .then(|| (info >> 3) as i8 - 8);
    let sat = SatMeas {
        svid: f.u8(o + 2),
        fcn,
        sigs: vec![m],
    };
    (sat, f.u8(o + 19) as usize)
}

/// The Type-2 sub-block at `o`, relative to the master's pseudorange `pr1`.
fn type2(f: &Le, o: usize, pr1: Option<f64>) -> SigMeas {
    let typ = f.u8(o);
    let info = f.u8(o + 5);
    let sig = signal_number(typ, info);
    let msb = f.u8(o + 3);
    let (code_msb, dopp_msb) = (signed(msb, 3), signed(msb >> 3, 5));
    let code_lsb = f.u16(o + 6);
    let (c_msb, c_lsb) = (f.i8(o + 4), f.u16(o + 8));
    let d_lsb = f.u16(o + 10);
    let lock = f.u8(o + 1);
    SigMeas {
        sig,
        antenna: typ >> 5,
        pr: pr1
            .filter(|_| code_msb != -4 || code_lsb != 0)
            .map(|p| p + code_msb as f64 * 65.536 + code_lsb as f64 * 0.001),
        carrier: (c_msb != -128 || c_lsb != 0)
            .then(|| (c_msb as i32 * 65536 + c_lsb as i32) as f64 * 0.001),
        doppler: (dopp_msb != -16 || d_lsb != 0)
            .then_some(dopp_msb as f64 * 6.5536 + d_lsb as f64 * 1e-4),
        cn0: cn0(f.u8(o + 2), sig),
        lock: (lock != u8::MAX).then_some(lock as u16),
        half: info & 4 != 0,
        type2: true,
    }
}

/// Decode a whole MeasEpoch block; `None` when its sub-block lengths are shorter than their
/// fields (Type-1 20 bytes, Type-2 12) or its sub-blocks run past its end.
pub fn decode_meas_epoch(b: &[u8]) -> Option<MeasEpoch> {
    if b.len() < 20 {
        return None;
    }
    let f = Le(b);
    let (n1, sb1, sb2) = (f.u8(14) as usize, f.u8(15) as usize, f.u8(16) as usize);
    if n1 > 0 && sb1 < 20 {
        return None;
    }
    let (tow_ms, wnc) = time_tag(b);
    let mut sats = Vec::with_capacity(n1.min((b.len() - 20) / 20));
    let mut o = 20;
    for _ in 0..n1 {
        if o + sb1 > b.len() {
            return None;
        }
        let (mut sat, n2) = type1(&f, o);
        o += sb1;
        if n2 > 0 && (sb2 < 12 || o + n2 * sb2 > b.len()) {
            return None;
        }
        let pr1 = sat.sigs[0].pr;
        for _ in 0..n2 {
            sat.sigs.push(type2(&f, o, pr1));
            o += sb2;
        }
        sats.push(sat);
    }
    Some(MeasEpoch {
        tow_ms,
        wnc,
        flags: f.u8(17),
        sats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::sbf::{block, MEAS_EPOCH};

    /// A MeasEpoch with one GPS satellite: L1 C/A in Type-1, L2P in a Type-2, values worked
    /// out by hand from the SBF definitions.
    #[test]
    fn meas_epoch_fields_by_hand() {
        let mut body = vec![0u8; 12];
        body[0..4].copy_from_slice(&345_600_100u32.to_le_bytes());
        body[4..6].copy_from_slice(&2300u16.to_le_bytes());
        body[6] = 1; // N1
        body[7] = 20; // SB1Length
        body[8] = 12; // SB2Length
        let mut t1 = [0u8; 20];
        t1[1] = 0; // GPS L1 C/A, main antenna
        t1[2] = 5; // G05
        t1[3] = 5; // CodeMSB 5
        t1[4..8].copy_from_slice(&1_234_567u32.to_le_bytes());
        t1[8..12].copy_from_slice(&(-12_345_678i32).to_le_bytes());
        t1[12..14].copy_from_slice(&40_000u16.to_le_bytes());
        t1[14] = (-2i8) as u8;
        t1[15] = 160;
        t1[16..18].copy_from_slice(&75u16.to_le_bytes());
        t1[18] = 4; // half-cycle ambiguity
        t1[19] = 1; // N2
        let mut t2 = [0u8; 12];
        t2[0] = 2; // GPS L2P
        t2[1] = 74;
        t2[2] = 100;
        t2[3] = (0b11111 << 3) | 0b001; // Doppler MSB −1 (bits 3–7), code MSB +1 (bits 0–2)
        t2[4] = 1; // CarrierMSB
        t2[6..8].copy_from_slice(&500u16.to_le_bytes());
        t2[8..10].copy_from_slice(&7u16.to_le_bytes());
        t2[10..12].copy_from_slice(&30_000u16.to_le_bytes());
        body.extend_from_slice(&t1);
        body.extend_from_slice(&t2);
        let m = decode_meas_epoch(&block(MEAS_EPOCH, 1, &body)).unwrap();
        assert_eq!((m.tow_ms, m.wnc), (Some(345_600_100), Some(2300)));
        let s = &m.sats[0];
        assert_eq!((s.svid, s.fcn, s.sigs.len()), (5, None, 2));
        let (a, b) = (s.sigs[0], s.sigs[1]);
        // 5 · 4294967.296 + 1234.567 m
        assert!((a.pr.unwrap() - 21_476_071.047).abs() < 1e-6);
        // (−2 · 65536 + 40000) · 0.001 cycles
        assert!((a.carrier.unwrap() - -91.072).abs() < 1e-9);
        assert!((a.doppler.unwrap() - -1234.5678).abs() < 1e-9);
        assert_eq!((a.cn0, a.lock, a.half), (Some(50.0), Some(75), true));
        // + 1 · 65.536 + 0.5 m
        assert!((b.pr.unwrap() - 21_476_137.083).abs() < 1e-6);
        assert!((b.carrier.unwrap() - 65.543).abs() < 1e-9);
        // −1 · 6.5536 + 3.0 Hz
        assert!((b.doppler.unwrap() - -3.5536).abs() < 1e-9);
        // L2P: no +10 dB
        assert_eq!(
            (b.cn0, b.lock, b.half, b.type2),
            (Some(25.0), Some(74), false, true)
        );
        // a Type-2 count that runs past the block is refused
        let mut short = body.clone();
        short[12 + 19] = 2;
        assert!(decode_meas_epoch(&block(MEAS_EPOCH, 1, &short)).is_none());
    }

    #[test]
    fn do_not_use_values_and_glonass_channel() {
        let mut body = vec![0u8; 12];
        body[6] = 1;
        body[7] = 20;
        body[8] = 12;
        let mut t1 = [0u8; 20];
        t1[1] = 8; // GLONASS L1 C/A
        t1[2] = 40; // R03
        t1[8..12].copy_from_slice(&i32::MIN.to_le_bytes());
        t1[14] = 0x80; // CarrierMSB −128 and LSB 0: no phase
        t1[15] = 255;
        t1[16..18].copy_from_slice(&u16::MAX.to_le_bytes());
        t1[18] = 5 << 3; // frequency number −3 (+ 8)
        body.extend_from_slice(&t1);
        let m = decode_meas_epoch(&block(MEAS_EPOCH, 1, &body)).unwrap();
        let s = &m.sats[0];
        assert_eq!(s.fcn, Some(-3));
        let a = s.sigs[0];
        assert_eq!(
            (a.pr, a.carrier, a.doppler, a.cn0, a.lock),
            (None, None, None, None, None)
        );
        // signal numbers ≥ 32 through ObsInfo
        assert_eq!(signal_number(31, 2 << 3), 34);
    }
}
