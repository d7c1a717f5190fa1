//! Bytes to text: json.loads(bytes) = bytes.decode(json.detect_encoding(b), 'surrogatepass'), as code points.

pub(super) fn decode_text(b: &[u8]) -> Option<Vec<u32>> {
    if b.starts_with(&[0, 0, 0xFE, 0xFF]) {
        return utf32(&b[4..], true);
    }
    if b.starts_with(&[0xFF, 0xFE, 0, 0]) {
        return utf32(&b[4..], false);
    }
    if b.starts_with(&[0xFE, 0xFF]) {
        return utf16(&b[2..], true);
    }
    if b.starts_with(&[0xFF, 0xFE]) {
        return utf16(&b[2..], false);
    }
    if let Some(rest) = b.strip_prefix(&[0xEF, 0xBB, 0xBF]) {
        return utf8(rest);
    }
    if b.len() >= 4 {
        if b[0] == 0 {
            return if b[1] != 0 { utf16(b, true) } else { utf32(b, true) };
        }
        if b[1] == 0 {
            return if b[2] != 0 || b[3] != 0 { utf16(b, false) } else { utf32(b, false) };
        }
    } else if b.len() == 2 {
        if b[0] == 0 {
            return utf16(b, true);
        }
        if b[1] == 0 {
            return utf16(b, false);
        }
    }
    utf8(b)
}

/// Strict UTF-8, except that 'surrogatepass' lets 3-byte encodings of surrogates (ED A0 80..ED BF BF) through.
fn utf8(mut b: &[u8]) -> Option<Vec<u32>> {
    let mut out = Vec::with_capacity(b.len());
    loop {
        match std::str::from_utf8(b) {
            Ok(s) => {
                out.extend(s.chars().map(u32::from));
                return Some(out);
            }
            Err(e) => {
                let (good, rest) = b.split_at(e.valid_up_to());
                out.extend(std::str::from_utf8(good).ok()?.chars().map(u32::from));
                match rest {
                    [0xED, c1 @ 0xA0..=0xBF, c2 @ 0x80..=0xBF, ..] => {
                        out.push(0xD000 | (u32::from(c1 & 0x3F) << 6) | u32::from(c2 & 0x3F));
                        b = &rest[3..];
                    }
                    _ => return None,
                }
            }
        }
    }
}

fn utf16(b: &[u8], big_endian: bool) -> Option<Vec<u32>> {
    if !b.len().is_multiple_of(2) {
        return None; // truncated data: not a surrogate, so 'surrogatepass' does not excuse it
    }
    let units: Vec<u32> = b
        .chunks_exact(2)
        .map(|c| {
            u32::from(if big_endian { u16::from_be_bytes([c[0], c[1]]) } else { u16::from_le_bytes([c[0], c[1]]) })
        })
        .collect();
    let mut out = Vec::with_capacity(units.len());
    let mut i = 0;
    while i < units.len() {
        let u = units[i];
        match units.get(i + 1) {
            Some(&l) if (0xD800..0xDC00).contains(&u) && (0xDC00..0xE000).contains(&l) => {
                out.push(0x10000 + ((u - 0xD800) << 10) + (l - 0xDC00));
                i += 2;
            }
            _ => {
                out.push(u); // lone surrogates pass
                i += 1;
            }
        }
    }
    Some(out)
}

fn utf32(b: &[u8], big_endian: bool) -> Option<Vec<u32>> {
    if !b.len().is_multiple_of(4) {
        return None;
    }
    b.chunks_exact(4)
        .map(|c| {
            let a = [c[0], c[1], c[2], c[3]];
            let u = if big_endian { u32::from_be_bytes(a) } else { u32::from_le_bytes(a) };
            (u <= 0x10FFFF).then_some(u)
        })
        .collect()
}
