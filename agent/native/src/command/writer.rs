//! The writer: json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False) (ensure_ascii): the
//! canonical text the signature covers.

use super::pyjson::Json;

/// Python's `repr(float)`: the shortest digits that round-trip, positional for 1e-4 <= |v| < 1e16, else
/// exponent form with a sign and at least two exponent digits.
pub fn float_repr(v: f64) -> String {
    if v == 0.0 {
        return if v.is_sign_negative() { "-0.0" } else { "0.0" }.to_string();
    }
    // Rust's `{:e}` prints the same shortest round-trip digits (closest among the shortest) as Python's repr,
    // except on an exact tie between two shortest candidates, which Python breaks to the even last digit.
    let sci = format!("{:e}", v.abs());
    let (mantissa, exp) = sci.split_once('e').expect("{:e} has an exponent");
    let mut exp: i32 = exp.parse().expect("integer exponent");
    let mut digits = mantissa.replace('.', "");
    if let Some((even, even_exp)) = tie_to_even(v.abs(), &digits) {
        digits = even;
        exp = even_exp;
    }
    let sign = if v < 0.0 { "-" } else { "" };
    if !(-4..16).contains(&exp) {
        let (first, rest) = digits.split_at(1);
        let dot = if rest.is_empty() { String::new() } else { format!(".{rest}") };
        let esign = if exp < 0 { '-' } else { '+' };
        return format!("{sign}{first}{dot}e{esign}{:02}", exp.abs());
    }
    if exp < 0 {
        return format!("{sign}0.{}{digits}", "0".repeat((-exp - 1) as usize));
    }
    let int_len = exp as usize + 1;
    if digits.len() > int_len {
        format!("{sign}{}.{}", &digits[..int_len], &digits[int_len..])
    } else {
        format!("{sign}{digits}{}.0", "0".repeat(int_len - digits.len()))
    }
}

/// When `v`'s exact decimal value lies exactly halfway between two candidates of `shortest`'s length (a
/// binary fraction such as 0.87348175048828125), the candidate with the even last digit and its exponent.
fn tie_to_even(v: f64, shortest: &str) -> Option<(String, i32)> {
    let n = shortest.len();
    // Exact digits: a double's decimal expansion that ends within n + 40 digits is printed exactly.
    let exact = format!("{:.*e}", n + 40, v);
    let (mantissa, exp) = exact.split_once('e')?;
    let exp: i32 = exp.parse().ok()?;
    let all = mantissa.replace('.', "");
    let (lower, rest) = all.split_at(n);
    if !rest.starts_with('5') || !rest[1..].bytes().all(|b| b == b'0') {
        return None;
    }
    if (lower.as_bytes()[n - 1] - b'0') % 2 == 0 {
        return Some((lower.to_string(), exp));
    }
    // The upper candidate: lower + 1 in its last digit, with the carry.
    let mut up: Vec<u8> = lower.bytes().collect();
    let mut k = n;
    loop {
        if k == 0 {
            up.insert(0, b'1');
            up.pop();
            return Some((String::from_utf8(up).ok()?, exp + 1));
        }
        k -= 1;
        if up[k] == b'9' {
            up[k] = b'0';
        } else {
            up[k] += 1;
            break;
        }
    }
    Some((String::from_utf8(up).ok()?, exp))
}

fn write_str(s: &[u32], out: &mut Vec<u8>) {
    out.push(b'"');
    for &c in s {
        match c {
            0x22 => out.extend_from_slice(b"\\\""),
            0x5C => out.extend_from_slice(b"\\\\"),
            0x0A => out.extend_from_slice(b"\\n"),
            0x0D => out.extend_from_slice(b"\\r"),
            0x09 => out.extend_from_slice(b"\\t"),
            0x08 => out.extend_from_slice(b"\\b"),
            0x0C => out.extend_from_slice(b"\\f"),
            0x20..=0x7E => out.push(c as u8),
            0x10000.. => {
                let v = c - 0x10000;
                out.extend_from_slice(
                    format!("\\u{:04x}\\u{:04x}", 0xD800 | (v >> 10), 0xDC00 | (v & 0x3FF)).as_bytes(),
                );
            }
            _ => out.extend_from_slice(format!("\\u{c:04x}").as_bytes()),
        }
    }
    out.push(b'"');
}

fn write(v: &Json, out: &mut Vec<u8>) {
    match v {
        Json::Null => out.extend_from_slice(b"null"),
        Json::Bool(b) => out.extend_from_slice(if *b { b"true" } else { b"false" }),
        Json::Int(n) => {
            if n.negative {
                out.push(b'-');
            }
            out.extend_from_slice(n.digits.as_bytes());
        }
        Json::Float(f) => out.extend_from_slice(float_repr(*f).as_bytes()),
        Json::Str(s) => write_str(s, out),
        Json::Array(items) => {
            out.push(b'[');
            for (k, item) in items.iter().enumerate() {
                if k > 0 {
                    out.push(b',');
                }
                write(item, out);
            }
            out.push(b']');
        }
        Json::Object(map) => {
            out.push(b'{');
            for (k, (name, item)) in map.iter().enumerate() {
                if k > 0 {
                    out.push(b',');
                }
                write_str(name, out);
                out.push(b':');
                write(item, out);
            }
            out.push(b'}');
        }
    }
}

/// The canonical text the signature covers.
pub fn canonical(v: &Json) -> Vec<u8> {
    let mut out = Vec::new();
    write(v, &mut out);
    out
}
