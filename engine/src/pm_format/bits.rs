//! Bit-level writing and reading for the compact `.pm` form: fixed-width fields and adaptive
//! Golomb–Rice codes (the parameter follows the running mean of the values, as in LOCO-I).

/// Writes bits, least significant first, into bytes.
#[derive(Debug, Default)]
pub(crate) struct BitWriter {
    bytes: Vec<u8>,
    /// Bits used in the last byte (0 when it is full or there is none).
    used: u32,
}

impl BitWriter {
    /// The low `width` bits of `value` (`width` ≤ 64).
    pub fn put(&mut self, value: u64, width: u32) {
        let mut value = if width < 64 { value & ((1u64 << width) - 1) } else { value };
        let mut left = width;
        while left > 0 {
            if self.used == 0 {
                self.bytes.push(0);
            }
            let room = 8 - self.used;
            let take = room.min(left);
            let last = self.bytes.last_mut().expect("pushed");
            *last |= ((value & ((1u64 << take) - 1)) as u8) << self.used;
            value >>= take;
            left -= take;
            self.used = (self.used + take) % 8;
        }
    }

    pub fn bit(&mut self, bit: bool) {
        self.put(bit as u64, 1);
    }

    /// `n` one bits (a unary count), however many: [`BitWriter::put`] takes at most 64 at once.
    pub fn ones(&mut self, mut n: usize) {
        while n > 0 {
            let take = n.min(32);
            self.put((1u64 << take) - 1, take as u32);
            n -= take;
        }
    }

    /// The bytes written; the last one padded with zeros.
    pub fn finish(self) -> Vec<u8> {
        self.bytes
    }
}

/// Reads what a [`BitWriter`] wrote; running past the end is an error.
#[derive(Debug)]
pub(crate) struct BitReader<'a> {
    bytes: &'a [u8],
    /// Bits read so far.
    at: u64,
}

/// The reader ran out of bits: the section is truncated or lies about its contents.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct OutOfBits;

impl<'a> BitReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        BitReader { bytes, at: 0 }
    }

    /// Bits not read yet.
    pub fn remaining(&self) -> u64 {
        8 * self.bytes.len() as u64 - self.at
    }

    pub fn get(&mut self, width: u32) -> Result<u64, OutOfBits> {
        if (width as u64) > self.remaining() {
            return Err(OutOfBits);
        }
        let mut value = 0u64;
        let mut done = 0;
        while done < width {
            let byte = self.bytes[(self.at / 8) as usize] as u64;
            let offset = (self.at % 8) as u32;
            let take = (8 - offset).min(width - done);
            value |= ((byte >> offset) & ((1 << take) - 1)) << done;
            done += take;
            self.at += take as u64;
        }
        Ok(value)
    }

    pub fn bit(&mut self) -> Result<bool, OutOfBits> {
        Ok(self.get(1)? == 1)
    }

    /// Whether only zero padding (fewer than 8 bits) is left.
    pub fn at_end(&self) -> bool {
        self.remaining() < 8 && {
            let mut copy = BitReader { bytes: self.bytes, at: self.at };
            copy.get(self.remaining() as u32) == Ok(0)
        }
    }
}

/// Bits needed to write any value below `count` (0 when `count` ≤ 1).
pub(crate) fn width_for(count: u64) -> u32 {
    if count <= 1 { 0 } else { 64 - (count - 1).leading_zeros() }
}

pub(crate) fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

pub(crate) fn unzigzag(v: u64) -> i64 {
    ((v >> 1) as i64) ^ -((v & 1) as i64)
}

/// Quotients at or above this are escaped: the escape is this many ones, then the value's bit
/// length (6 bits) and the value itself.
const ESCAPE: u64 = 24;

/// An adaptive Golomb–Rice code for unsigned values: the parameter `k` is the smallest with
/// `count · 2^k ≥ sum` over the recent values, so that small values cost few bits.
#[derive(Debug, Clone)]
pub(crate) struct Rice {
    sum: u64,
    count: u64,
}

impl Default for Rice {
    fn default() -> Self {
        Rice { sum: 4, count: 1 }
    }
}

impl Rice {
    fn k(&self) -> u32 {
        let mut k = 0;
        while (self.count << k) < self.sum && k < 40 {
            k += 1;
        }
        k
    }

    fn update(&mut self, value: u64) {
        self.sum = self.sum.saturating_add(value);
        self.count += 1;
        if self.count >= 64 {
            self.sum /= 2;
            self.count /= 2;
        }
    }

    pub fn put(&mut self, w: &mut BitWriter, value: u64) {
        let k = self.k();
        let quotient = value >> k;
        if quotient < ESCAPE {
            w.put((1u64 << quotient) - 1, quotient as u32);
            w.bit(false);
            w.put(value, k);
        } else {
            w.put((1u64 << ESCAPE) - 1, ESCAPE as u32);
            let bits = 64 - value.leading_zeros();
            w.put(bits as u64, 7);
            w.put(value, bits);
        }
        self.update(value);
    }

    pub fn get(&mut self, r: &mut BitReader) -> Result<u64, OutOfBits> {
        let k = self.k();
        let mut quotient = 0;
        while quotient < ESCAPE && r.bit()? {
            quotient += 1;
        }
        let value = if quotient < ESCAPE {
            (quotient << k) | r.get(k)?
        } else {
            let bits = r.get(7)? as u32;
            if bits > 64 {
                return Err(OutOfBits);
            }
            r.get(bits)?
        };
        self.update(value);
        Ok(value)
    }

    /// A signed value, zigzag-mapped.
    pub fn put_signed(&mut self, w: &mut BitWriter, value: i64) {
        self.put(w, zigzag(value));
    }

    pub fn get_signed(&mut self, r: &mut BitReader) -> Result<i64, OutOfBits> {
        Ok(unzigzag(self.get(r)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_and_codes_read_back() {
        let mut w = BitWriter::default();
        let mut rice = Rice::default();
        let values: Vec<i64> = (0..500).map(|i: i64| (i * 7919 % 1000) - 500).chain([i64::MIN / 2, 1 << 40]).collect();
        for (i, &v) in values.iter().enumerate() {
            w.put(i as u64, width_for(values.len() as u64));
            rice.put_signed(&mut w, v);
            w.bit(v > 0);
        }
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        let mut rice = Rice::default();
        for (i, &v) in values.iter().enumerate() {
            assert_eq!(r.get(width_for(values.len() as u64)).unwrap(), i as u64);
            assert_eq!(rice.get_signed(&mut r).unwrap(), v);
            assert_eq!(r.bit().unwrap(), v > 0);
        }
        assert!(r.at_end());
        assert_eq!(r.get(9), Err(OutOfBits));
    }

    #[test]
    fn widths() {
        assert_eq!([0, 1, 2, 3, 4, 5, 256, 257].map(width_for), [0, 0, 1, 2, 2, 3, 8, 9]);
    }
}
