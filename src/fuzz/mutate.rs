//! Mutations of real input files: truncation, byte flips, number swaps and
//! (for JSON) structural changes, all driven by a seeded [`Pcg32`] so that
//! every mutated input can be rebuilt from its seed and index.

use serde_json::Value;

use crate::rng::Pcg32;

/// Numbers swapped into files: zero, negatives, overflow to infinity in f32,
/// NaN spellings, huge and tiny magnitudes, integers past u32 and u64.
pub const HOSTILE_NUMBERS: [&str; 20] = [
    "0",
    "-1",
    "1e39",
    "-1e39",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "1e-45",
    "-0",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999999",
    "65537",
    "16385",
    "1e12",
    "3.4e38",
    "0.5",
];

/// Byte ranges of the number tokens in `text`.
pub fn number_spans(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        let starts = c.is_ascii_digit() || (c == b'-' && text.get(i + 1).is_some_and(|d| d.is_ascii_digit()));
        let prev_ok = i == 0 || !(text[i - 1].is_ascii_alphanumeric() || text[i - 1] == b'_');
        if starts && prev_ok {
            let s = i;
            i += 1;
            while i < text.len() && (text[i].is_ascii_digit() || matches!(text[i], b'.' | b'e' | b'E' | b'+' | b'-')) {
                i += 1;
            }
            spans.push((s, i));
        } else {
            i += 1;
        }
    }
    spans
}

/// Replace one number of `text` with a hostile one; returns a description.
pub fn swap_number(text: &mut Vec<u8>, rng: &mut Pcg32) -> String {
    let spans = number_spans(text);
    if spans.is_empty() {
        return "no number to swap".into();
    }
    let (s, e) = spans[rng.below(spans.len() as u32) as usize];
    let n = HOSTILE_NUMBERS[rng.below(HOSTILE_NUMBERS.len() as u32) as usize];
    let old = String::from_utf8_lossy(&text[s..e]).to_string();
    text.splice(s..e, n.bytes());
    format!("number {old} at byte {s} -> {n}")
}

/// Cut `text` at a random byte.
pub fn truncate(text: &mut Vec<u8>, rng: &mut Pcg32) -> String {
    let k = rng.below(text.len() as u32 + 1) as usize;
    text.truncate(k);
    format!("truncated at byte {k}")
}

/// Replace a random byte with a random value.
pub fn flip_byte(text: &mut [u8], rng: &mut Pcg32) -> String {
    if text.is_empty() {
        return "empty".into();
    }
    let k = rng.below(text.len() as u32) as usize;
    let b = rng.next_u32() as u8;
    text[k] = b;
    format!("byte {k} -> {b:#04x}")
}

/// Duplicate a random line many times (large counts, long files).
pub fn repeat_line(text: &mut Vec<u8>, rng: &mut Pcg32) -> String {
    let lines: Vec<&[u8]> = text.split(|&b| b == b'\n').collect();
    let k = rng.below(lines.len() as u32) as usize;
    let times = 1 + rng.below(2000) as usize;
    let mut out = Vec::with_capacity(text.len() + times * (lines[k].len() + 1));
    for (i, l) in lines.iter().enumerate() {
        let n = if i == k { times } else { 1 };
        for _ in 0..n {
            out.extend_from_slice(l);
            out.push(b'\n');
        }
    }
    *text = out;
    format!("line {} repeated {times} times", k + 1)
}

/// One to four random byte-level mutations.
pub fn bytes(text: &mut Vec<u8>, rng: &mut Pcg32) -> String {
    let n = 1 + rng.below(4);
    let mut what = Vec::new();
    for _ in 0..n {
        what.push(match rng.below(10) {
            0 => truncate(text, rng),
            1 | 2 => flip_byte(text, rng),
            3 => repeat_line(text, rng),
            _ => swap_number(text, rng),
        });
    }
    what.join("; ")
}

fn collect_paths(v: &Value, path: &mut Vec<PathStep>, out: &mut Vec<Vec<PathStep>>) {
    out.push(path.clone());
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                path.push(PathStep::Key(k.clone()));
                collect_paths(c, path, out);
                path.pop();
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                path.push(PathStep::Index(i));
                collect_paths(c, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

/// One step of a JSON path.
#[derive(Clone, Debug)]
enum PathStep {
    Key(String),
    Index(usize),
}

fn at<'a>(v: &'a mut Value, path: &[PathStep]) -> &'a mut Value {
    let mut cur = v;
    for s in path {
        cur = match (s, cur) {
            (PathStep::Key(k), Value::Object(m)) => m.get_mut(k).expect("path from collect_paths"),
            (PathStep::Index(i), Value::Array(a)) => &mut a[*i],
            _ => unreachable!("path from collect_paths"),
        };
    }
    cur
}

fn show(path: &[PathStep]) -> String {
    let mut s = String::new();
    for p in path {
        match p {
            PathStep::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            PathStep::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    if s.is_empty() { "(root)".into() } else { s }
}

/// A structural mutation of JSON text (objects to arrays, unknown or missing
/// fields, wrong types, huge values, repeated array elements); falls back to
/// a byte mutation when `text` is not JSON.
pub fn json(text: &mut Vec<u8>, rng: &mut Pcg32) -> String {
    let Ok(mut v) = serde_json::from_slice::<Value>(text) else { return bytes(text, rng) };
    let mut paths = Vec::new();
    collect_paths(&v, &mut Vec::new(), &mut paths);
    let path = paths[rng.below(paths.len() as u32) as usize].clone();
    let node = at(&mut v, &path);
    let what = match rng.below(9) {
        0 => {
            // serde's sequence form of a struct: the values in order.
            if let Value::Object(m) = node {
                *node = Value::Array(m.values().cloned().collect());
                "object -> array of its values"
            } else {
                *node = Value::Array(vec![node.clone()]);
                "value -> one-element array"
            }
        }
        1 => {
            if let Value::Object(m) = node {
                m.insert("unknown_field".into(), Value::from(1));
                "unknown field added"
            } else {
                *node = Value::Null;
                "value -> null"
            }
        }
        2 => {
            if let Value::Object(m) = node
                && let Some(k) = m.keys().nth(rng.below(m.len().max(1) as u32) as usize).cloned()
            {
                m.remove(&k);
                "field removed"
            } else {
                *node = Value::from("text");
                "value -> string"
            }
        }
        3 => {
            *node = Value::from(rng.next_u32() as i64 - (1 << 31));
            "value -> random integer"
        }
        4 => {
            *node = serde_json::from_str("1e39").unwrap_or(Value::Null);
            "value -> 1e39"
        }
        5 => {
            if let Value::Array(a) = node
                && !a.is_empty()
            {
                let first = a[0].clone();
                let n = 1 + rng.below(5000) as usize;
                a.extend(std::iter::repeat_n(first, n));
                "array element repeated"
            } else {
                *node = Value::Array(vec![]);
                "value -> empty array"
            }
        }
        6 => {
            *node = Value::from(-1);
            "value -> -1"
        }
        7 => {
            *node = Value::Bool(true);
            "value -> true"
        }
        _ => {
            *node = Value::Object(Default::default());
            "value -> {}"
        }
    };
    let out = serde_json::to_vec_pretty(&v).unwrap_or_default();
    *text = out;
    format!("{} at {}", what, show(&path))
}
