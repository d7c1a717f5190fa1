//! The reader: CPython's json scanner (Modules/_json.c) with decode's parse_constant/parse_float.

use std::collections::BTreeMap;

use super::pyjson::{key, Json, PyInt, PyStr};
use super::text::decode_text;
use super::{MAX_DEPTH, MAX_INT_DIGITS};

struct Reader<'a> {
    s: &'a [u32],
    i: usize,
}

type Parsed<T> = Result<T, ()>;

fn is_digit(c: u32) -> bool {
    (0x30..=0x39).contains(&c)
}

fn hex4(s: &[u32]) -> Option<u32> {
    if s.len() < 4 {
        return None;
    }
    s[..4].iter().try_fold(0u32, |acc, &c| Some(acc * 16 + char::from_u32(c)?.to_digit(16)?))
}

impl Reader<'_> {
    fn peek(&self) -> Option<u32> {
        self.s.get(self.i).copied()
    }

    fn skip_ws(&mut self) {
        while matches!(self.peek(), Some(0x20 | 0x09 | 0x0A | 0x0D)) {
            self.i += 1;
        }
    }

    fn literal(&mut self, word: &str, v: Json) -> Parsed<Json> {
        let w = key(word);
        if self.s[self.i..].starts_with(&w) {
            self.i += w.len();
            Ok(v)
        } else {
            Err(())
        }
    }

    fn value(&mut self, depth: usize) -> Parsed<Json> {
        match char::from_u32(self.peek().ok_or(())?) {
            Some('"') => {
                self.i += 1;
                Ok(Json::Str(self.string()?))
            }
            Some('{') => self.object(depth + 1),
            Some('[') => self.array(depth + 1),
            Some('n') => self.literal("null", Json::Null),
            Some('t') => self.literal("true", Json::Bool(true)),
            Some('f') => self.literal("false", Json::Bool(false)),
            // NaN, Infinity, -Infinity: decode's parse_constant refuses them; anything else there is no JSON
            Some('N' | 'I') => Err(()),
            _ => self.number(),
        }
    }

    /// After the opening quote.
    fn string(&mut self) -> Parsed<PyStr> {
        let mut out = Vec::new();
        loop {
            let c = self.peek().ok_or(())?;
            self.i += 1;
            match c {
                0x22 => return Ok(out),
                0x5C => {
                    let e = char::from_u32(self.peek().ok_or(())?).ok_or(())?;
                    self.i += 1;
                    let v = match e {
                        '"' | '\\' | '/' => u32::from(e),
                        'b' => 0x08,
                        'f' => 0x0C,
                        'n' => 0x0A,
                        'r' => 0x0D,
                        't' => 0x09,
                        'u' => {
                            let mut v = hex4(&self.s[self.i..]).ok_or(())?;
                            self.i += 4;
                            // A high surrogate escape followed by a low one is one character; else it stays lone.
                            if (0xD800..0xDC00).contains(&v) && self.s[self.i..].starts_with(&[0x5C, 0x75]) {
                                let low = hex4(&self.s[self.i + 2..]).ok_or(())?;
                                if (0xDC00..0xE000).contains(&low) {
                                    v = 0x10000 + ((v - 0xD800) << 10) + (low - 0xDC00);
                                    self.i += 6;
                                }
                            }
                            v
                        }
                        _ => return Err(()),
                    };
                    out.push(v);
                }
                0..=0x1F => return Err(()), // strict: no raw control characters
                _ => out.push(c),
            }
        }
    }

    fn object(&mut self, depth: usize) -> Parsed<Json> {
        if depth > MAX_DEPTH {
            return Err(());
        }
        self.i += 1;
        let mut map = BTreeMap::new();
        self.skip_ws();
        if self.peek() == Some(0x7D) {
            self.i += 1;
            return Ok(Json::Object(map));
        }
        loop {
            if self.peek() != Some(0x22) {
                return Err(());
            }
            self.i += 1;
            let k = self.string()?;
            self.skip_ws();
            if self.peek() != Some(0x3A) {
                return Err(());
            }
            self.i += 1;
            self.skip_ws();
            let v = self.value(depth)?;
            map.insert(k, v); // a repeated key keeps its last value, as in a Python dict
            self.skip_ws();
            match self.peek() {
                Some(0x7D) => {
                    self.i += 1;
                    return Ok(Json::Object(map));
                }
                Some(0x2C) => {
                    self.i += 1;
                    self.skip_ws();
                }
                _ => return Err(()),
            }
        }
    }

    fn array(&mut self, depth: usize) -> Parsed<Json> {
        if depth > MAX_DEPTH {
            return Err(());
        }
        self.i += 1;
        let mut items = Vec::new();
        self.skip_ws();
        if self.peek() == Some(0x5D) {
            self.i += 1;
            return Ok(Json::Array(items));
        }
        loop {
            items.push(self.value(depth)?);
            self.skip_ws();
            match self.peek() {
                Some(0x5D) => {
                    self.i += 1;
                    return Ok(Json::Array(items));
                }
                Some(0x2C) => {
                    self.i += 1;
                    self.skip_ws();
                }
                _ => return Err(()),
            }
        }
    }

    /// -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][-+]?[0-9]+)? as the scanner matches it (a dangling "." or "e" is
    /// left for the caller, where it is a syntax error).
    fn number(&mut self) -> Parsed<Json> {
        let s = self.s;
        let start = self.i;
        let mut i = start;
        if s.get(i) == Some(&0x2D) {
            i += 1;
        }
        match s.get(i) {
            Some(&c) if (0x31..=0x39).contains(&c) => {
                i += 1;
                while s.get(i).is_some_and(|&c| is_digit(c)) {
                    i += 1;
                }
            }
            Some(0x30) => i += 1,
            _ => return Err(()),
        }
        let int_end = i;
        let mut is_float = false;
        if s.get(i) == Some(&0x2E) && s.get(i + 1).is_some_and(|&c| is_digit(c)) {
            is_float = true;
            i += 2;
            while s.get(i).is_some_and(|&c| is_digit(c)) {
                i += 1;
            }
        }
        if matches!(s.get(i), Some(0x65 | 0x45)) {
            let e = i;
            i += 1;
            if matches!(s.get(i), Some(0x2B | 0x2D)) {
                i += 1;
            }
            let digits_at = i;
            while s.get(i).is_some_and(|&c| is_digit(c)) {
                i += 1;
            }
            if i > digits_at {
                is_float = true;
            } else {
                i = e;
            }
        }
        self.i = i;
        // ASCII only from here on, so the code points are bytes.
        let text: String = s[start..i].iter().map(|&c| c as u8 as char).collect();
        if is_float {
            let v: f64 = text.parse().map_err(|_| ())?;
            return if v.is_finite() { Ok(Json::Float(v)) } else { Err(()) }; // decode's _finite
        }
        let negative = s[start] == 0x2D;
        let digits = text[usize::from(negative)..int_end - start].to_string();
        if digits.len() > MAX_INT_DIGITS {
            return Err(());
        }
        Ok(Json::Int(PyInt { negative: negative && digits != "0", digits }))
    }
}

/// `json.loads(data)` for bytes, with decode's refusals; None for anything Python raises on.
pub fn parse(data: &[u8]) -> Option<Json> {
    let text = decode_text(data)?;
    let mut r = Reader { s: &text, i: 0 };
    r.skip_ws();
    let v = r.value(0).ok()?;
    r.skip_ws();
    (r.i == text.len()).then_some(v)
}
