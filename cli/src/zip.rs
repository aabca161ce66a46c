//! A ZIP archive of deflated entries: what an FMU needs, written by hand (the format's local
//! headers, central directory and CRC-32; APPNOTE.TXT 6.3), the compression by miniz_oxide
//! (pure Rust raw DEFLATE, the implementation the standard library's backtraces use): the
//! shared library inside an FMU shrinks to about a third.

use std::io::{self, Write};

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320) of `data`.
pub(crate) fn crc32(data: &[u8]) -> u32 {
    let mut table = [0u32; 256];
    for (i, slot) in table.iter_mut().enumerate() {
        let mut c = i as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
        *slot = c;
    }
    !data.iter().fold(!0u32, |c, &b| {
        table[((c ^ u32::from(b)) & 0xff) as usize] ^ (c >> 8)
    })
}

/// Writes `entries` (`(path, bytes)`, paths with `/`) as a ZIP archive, each entry deflated
/// (method 8, raw DEFLATE by miniz_oxide at level 9) or stored (method 0) when deflating would
/// not make it smaller.
pub(crate) fn write_zip(out: &mut impl Write, entries: &[(&str, &[u8])]) -> io::Result<()> {
    let too_big = || io::Error::other("a ZIP entry of 4 GiB or more needs ZIP64");
    let mut offset: u32 = 0;
    let mut central = Vec::new();
    for (name, data) in entries {
        let size = u32::try_from(data.len()).map_err(|_| too_big())?;
        let crc = crc32(data);
        let deflated = miniz_oxide::deflate::compress_to_vec(data, 9);
        let (method, body): (u16, &[u8]) = if deflated.len() < data.len() {
            (8, &deflated)
        } else {
            (0, data)
        };
        let packed = u32::try_from(body.len()).map_err(|_| too_big())?;
        let name_len = u16::try_from(name.len()).map_err(|_| too_big())?;
        // 1980-01-01 00:00: the format's epoch (a fixed time: the archive is reproducible).
        let (time, date) = (0u16, 0x21u16);
        let mut local = Vec::with_capacity(30 + name.len());
        local.extend_from_slice(&0x0403_4b50u32.to_le_bytes());
        for v in [20u16, 0, method, time, date] {
            local.extend_from_slice(&v.to_le_bytes());
        }
        for v in [crc, packed, size] {
            local.extend_from_slice(&v.to_le_bytes());
        }
        local.extend_from_slice(&name_len.to_le_bytes());
        local.extend_from_slice(&0u16.to_le_bytes());
        local.extend_from_slice(name.as_bytes());
        out.write_all(&local)?;
        out.write_all(body)?;
        central.extend_from_slice(&0x0201_4b50u32.to_le_bytes());
        for v in [20u16, 20, 0, method, time, date] {
            central.extend_from_slice(&v.to_le_bytes());
        }
        for v in [crc, packed, size] {
            central.extend_from_slice(&v.to_le_bytes());
        }
        for v in [name_len, 0, 0, 0, 0] {
            central.extend_from_slice(&v.to_le_bytes());
        }
        central.extend_from_slice(&0u32.to_le_bytes());
        central.extend_from_slice(&offset.to_le_bytes());
        central.extend_from_slice(name.as_bytes());
        offset = offset
            .checked_add(u32::try_from(local.len() + body.len()).map_err(|_| too_big())?)
            .ok_or_else(too_big)?;
    }
    let count = u16::try_from(entries.len()).map_err(|_| too_big())?;
    out.write_all(&central)?;
    let mut end = Vec::with_capacity(22);
    end.extend_from_slice(&0x0605_4b50u32.to_le_bytes());
    for v in [0u16, 0, count, count] {
        end.extend_from_slice(&v.to_le_bytes());
    }
    end.extend_from_slice(&(central.len() as u32).to_le_bytes());
    end.extend_from_slice(&offset.to_le_bytes());
    end.extend_from_slice(&0u16.to_le_bytes());
    out.write_all(&end)
}

#[cfg(test)]
mod tests {
    use super::crc32;

    /// An archive of a compressible and an incompressible entry: the first deflated (method
    /// 8), the second stored (method 0), and both read back to their bytes by inflating.
    #[test]
    fn entries_are_deflated_when_that_is_smaller_and_read_back() {
        let text = b"lieflow ".repeat(1000);
        let noise: Vec<u8> = (0u32..64)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
            .collect();
        let mut zip = Vec::new();
        super::write_zip(&mut zip, &[("a.txt", &text), ("b.bin", &noise)]).unwrap();
        assert!(zip.len() < text.len() / 10, "{} bytes", zip.len());
        let word = |at: usize| u16::from_le_bytes([zip[at], zip[at + 1]]);
        let long = |at: usize| u32::from_le_bytes(zip[at..at + 4].try_into().unwrap());
        // The first local header: method, sizes, name; then the deflated body.
        assert_eq!(word(8), 8);
        let (packed, size) = (long(18) as usize, long(22) as usize);
        assert_eq!(size, text.len());
        let body = &zip[30 + 5..30 + 5 + packed];
        assert_eq!(miniz_oxide::inflate::decompress_to_vec(body).unwrap(), text);
        assert_eq!(long(14), crc32(&text));
        // The second: stored as is.
        let second = 30 + 5 + packed;
        assert_eq!(word(second + 8), 0);
        assert_eq!(
            &zip[second + 30 + 5..second + 30 + 5 + noise.len()],
            &noise[..]
        );
    }

    #[test]
    fn crc32_of_the_check_string() {
        // The standard check value of CRC-32/ISO-HDLC.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }
}
