//! FMU state by value: `fmi2GetFMUstate` serialises the whole instance into a byte string,
//! `fmi2SetFMUstate` parses and checks it. The same bytes are what `fmi2SerializeFMUstate`
//! hands out, so a state restored into a different instance continues bit-identically.
//!
//! Layout (little-endian): magic `"SUSPFMU2"`, GUID (u64 length + bytes), FMI state (u8),
//! time, start time (f64), stop time (u8 flag + f64), model payload (u64 length + bytes),
//! for an instance its sample clock ticks the clock's state (ticks taken (u64), active (u8),
//! held outputs (u64 length + f64s)), FNV-1a 64 checksum of everything before it. A state
//! without the clock's part is laid out as before it existed.
//! A truncated, altered or foreign byte string is rejected before anything is changed.

use crate::state_machine::FmiState;

const MAGIC: &[u8; 8] = b"SUSPFMU2";

/// Appends values to a model's payload.
#[derive(Default)]
pub struct StateWriter {
    bytes: Vec<u8>,
}

impl StateWriter {
    pub fn f64(&mut self, v: f64) {
        self.bytes.extend_from_slice(&v.to_le_bytes());
    }
    pub fn u64(&mut self, v: u64) {
        self.bytes.extend_from_slice(&v.to_le_bytes());
    }
    pub fn bool(&mut self, v: bool) {
        self.bytes.push(v as u8);
    }
    /// A length-prefixed slice.
    pub fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for x in v {
            self.f64(*x);
        }
    }
    fn bytes(&mut self, v: &[u8]) {
        self.u64(v.len() as u64);
        self.bytes.extend_from_slice(v);
    }
    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }
}

/// Reads a model's payload back, with bounds checks.
pub struct StateReader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> StateReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        StateReader { bytes, pos: 0 }
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or("FMU state is truncated")?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }
    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    pub fn bool(&mut self) -> Result<bool, String> {
        match self.take(1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(format!("FMU state has invalid boolean byte {b}")),
        }
    }
    pub fn f64s(&mut self) -> Result<Vec<f64>, String> {
        let n = self.u64()? as usize;
        if n > (self.bytes.len() - self.pos) / 8 {
            return Err("FMU state is truncated".into());
        }
        (0..n).map(|_| self.f64()).collect()
    }
    /// A slice of exactly `n` values.
    pub fn f64s_exact(&mut self, n: usize, what: &str) -> Result<Vec<f64>, String> {
        let v = self.f64s()?;
        if v.len() != n {
            return Err(format!(
                "FMU state has {} values for {what}, expected {n}",
                v.len()
            ));
        }
        Ok(v)
    }
    fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.u64()? as usize;
        self.take(n)
    }
    pub fn finish(&self) -> Result<(), String> {
        if self.pos == self.bytes.len() {
            Ok(())
        } else {
            Err(format!(
                "FMU state has {} unexpected trailing bytes",
                self.bytes.len() - self.pos
            ))
        }
    }
}

/// FNV-1a's offset basis, the seed of [`fnv1a`] for the standard hash.
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a, 64 bit, from `seed` ([`FNV_OFFSET`] for the standard hash): the state's checksum,
/// a controller file's content hash, a description's GUID. It detects corruption and tells
/// contents apart, not tampering: nothing here is secret.
pub fn fnv1a(seed: u64, bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(seed, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fn checksum(bytes: &[u8]) -> u64 {
    fnv1a(FNV_OFFSET, bytes.iter().copied())
}

/// A decoded FMU state.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    pub state: FmiState,
    pub time: f64,
    /// What `fmi2SetupExperiment` set: a state taken in initialisation mode carries them into
    /// `fmi2ExitInitializationMode` of the instance it is restored into.
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub payload: Vec<u8>,
    /// The sample clock's state, for an instance its clock ticks (FMI 3.0's Event Mode).
    pub clock: Option<ClockSnapshot>,
}

/// What an instance its sample clock ticks keeps between ticks.
#[derive(Debug, Clone, PartialEq)]
pub struct ClockSnapshot {
    /// Ticks taken since the start: the next is at `startTime + ticks · interval`.
    pub ticks: u64,
    /// Activated (`fmi3SetClock`) and not yet ticked (`fmi3UpdateDiscreteStates`).
    pub active: bool,
    /// The outputs computed at the last tick, held until the next.
    pub held: Vec<f64>,
}

pub fn encode(guid: &str, snapshot: &Snapshot) -> Vec<u8> {
    let mut w = StateWriter::default();
    w.bytes.extend_from_slice(MAGIC);
    w.bytes(guid.as_bytes());
    w.bytes.push(snapshot.state.code());
    w.f64(snapshot.time);
    w.f64(snapshot.start_time);
    w.bool(snapshot.stop_time.is_some());
    w.f64(snapshot.stop_time.unwrap_or(0.0));
    w.bytes(&snapshot.payload);
    if let Some(c) = &snapshot.clock {
        w.u64(c.ticks);
        w.bool(c.active);
        w.f64s(&c.held);
    }
    let sum = checksum(&w.bytes);
    w.u64(sum);
    w.into_bytes()
}

pub fn decode(guid: &str, bytes: &[u8]) -> Result<Snapshot, String> {
    if bytes.len() < MAGIC.len() + 8 || &bytes[..MAGIC.len()] != MAGIC {
        return Err("byte string is not an FMU state of this project (bad magic)".into());
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    if checksum(body) != u64::from_le_bytes(sum.try_into().unwrap()) {
        return Err("FMU state is corrupted (checksum mismatch)".into());
    }
    let mut r = StateReader::new(&body[MAGIC.len()..]);
    let stored_guid = r.bytes()?;
    if stored_guid != guid.as_bytes() {
        return Err(format!(
            "FMU state belongs to GUID {}, not {guid}",
            String::from_utf8_lossy(stored_guid)
        ));
    }
    let state_byte = r.take(1)?[0];
    let state = FmiState::from_code(state_byte)
        .ok_or_else(|| format!("FMU state has invalid FMI state {state_byte}"))?;
    let time = r.f64()?;
    let start_time = r.f64()?;
    let has_stop = r.bool()?;
    let stop = r.f64()?;
    if !time.is_finite() || !start_time.is_finite() {
        return Err("FMU state has a non-finite time or start time".into());
    }
    let stop_time = has_stop.then_some(stop);
    if stop_time.is_some_and(|s| s.is_nan() || s < start_time) {
        return Err(format!(
            "FMU state has stop time {stop} before its start time {start_time}"
        ));
    }
    let payload = r.bytes()?.to_vec();
    let clock = if r.pos < r.bytes.len() {
        let (ticks, active, held) = (r.u64()?, r.bool()?, r.f64s()?);
        if held.iter().any(|v| !v.is_finite()) {
            return Err("FMU state has a non-finite held output".into());
        }
        Some(ClockSnapshot {
            ticks,
            active,
            held,
        })
    } else {
        None
    };
    r.finish()?;
    Ok(Snapshot {
        state,
        time,
        start_time,
        stop_time,
        payload,
        clock,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        let mut w = StateWriter::default();
        w.f64s(&[1.0, -2.5, f64::MIN_POSITIVE]);
        w.bool(true);
        encode(
            "{g}",
            &Snapshot {
                state: FmiState::StepComplete,
                time: 0.125,
                start_time: 0.0,
                stop_time: Some(10.0),
                payload: w.into_bytes(),
                clock: None,
            },
        )
    }

    #[test]
    fn round_trip_is_exact() {
        let s = decode("{g}", &sample()).unwrap();
        assert_eq!(s.state, FmiState::StepComplete);
        assert_eq!(s.time, 0.125);
        assert_eq!((s.start_time, s.stop_time), (0.0, Some(10.0)));
        let mut r = StateReader::new(&s.payload);
        assert_eq!(r.f64s().unwrap(), vec![1.0, -2.5, f64::MIN_POSITIVE]);
        assert!(r.bool().unwrap());
        r.finish().unwrap();
    }

    #[test]
    fn a_clock_state_round_trips_and_its_absence_keeps_the_old_layout() {
        let plain = sample();
        let mut snap = decode("{g}", &plain).unwrap();
        assert_eq!(snap.clock, None);
        assert_eq!(encode("{g}", &snap), plain);
        snap.clock = Some(ClockSnapshot {
            ticks: 7,
            active: true,
            held: vec![1.5, -2.0],
        });
        let clocked = encode("{g}", &snap);
        assert_eq!(decode("{g}", &clocked).unwrap(), snap);
        assert_every_byte_flip_is_rejected(&clocked);
    }

    /// Flipping any one bit of any byte of `good` makes it a state `decode` refuses.
    fn assert_every_byte_flip_is_rejected(good: &[u8]) {
        for i in 0..good.len() {
            let mut bad = good.to_vec();
            bad[i] ^= 0x40;
            assert!(
                decode("{g}", &bad).is_err(),
                "flipping byte {i} was accepted"
            );
        }
    }

    #[test]
    fn every_single_byte_corruption_and_every_truncation_is_rejected() {
        let good = sample();
        assert_every_byte_flip_is_rejected(&good);
        for i in 0..good.len() {
            assert!(
                decode("{g}", &good[..i]).is_err(),
                "truncation to {i} bytes was accepted"
            );
        }
        assert!(decode("{other}", &good).unwrap_err().contains("GUID"));
    }

    #[test]
    fn payload_reader_rejects_impossible_lengths() {
        let mut w = StateWriter::default();
        w.u64(u64::MAX);
        let bytes = w.into_bytes();
        assert!(StateReader::new(&bytes).f64s().is_err());
    }
}
