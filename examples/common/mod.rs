//! Shared plumbing for the examples: flag parsing with clear errors (exit code 2), the final
//! JSON summary line, and timing. Not part of the library API.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::str::FromStr;

/// Parsed `--flag value` pairs, checked against the flags an example declares.
pub struct Args {
    values: BTreeMap<String, String>,
    usage: String,
}

impl Args {
    /// Parses `std::env::args()`. `flags` lists `(name, value placeholder, help)`; `--help` prints
    /// them and exits 0; an unknown flag or a missing value prints the usage and exits 2.
    pub fn parse(about: &str, flags: &[(&str, &str, &str)]) -> Self {
        let mut usage = format!("{about}\n\nFlags:\n");
        for (name, value, help) in flags {
            let _ = writeln!(usage, "  --{name} {value:<10} {help}");
        }
        let _ = writeln!(usage, "  --help            print this help");
        let mut values = BTreeMap::new();
        let mut it = std::env::args().skip(1);
        while let Some(arg) = it.next() {
            if arg == "--help" || arg == "-h" {
                print!("{usage}");
                std::process::exit(0);
            }
            let Some(name) = arg.strip_prefix("--") else {
                fail(&usage, &format!("unexpected argument '{arg}'"));
            };
            let (name, inline) = match name.split_once('=') {
                Some((n, v)) => (n.to_string(), Some(v.to_string())),
                None => (name.to_string(), None),
            };
            if !flags.iter().any(|(n, _, _)| *n == name) {
                fail(&usage, &format!("unknown flag '--{name}'"));
            }
            let value = match inline.or_else(|| it.next()) {
                Some(v) => v,
                None => fail(&usage, &format!("flag '--{name}' needs a value")),
            };
            values.insert(name, value);
        }
        Self { values, usage }
    }

    /// The value of `--name` parsed as `T`, or `default`; a bad value exits 2.
    pub fn get<T: FromStr>(&self, name: &str, default: T) -> T {
        match self.values.get(name) {
            None => default,
            Some(v) => v
                .parse()
                .unwrap_or_else(|_| fail(&self.usage, &format!("bad value '{v}' for '--{name}'"))),
        }
    }

    /// The value of `--name` if given.
    pub fn opt(&self, name: &str) -> Option<&str> {
        self.values.get(name).map(String::as_str)
    }

    /// A positive, finite number from `--name`; exits 2 otherwise.
    pub fn positive(&self, name: &str, default: f64) -> f64 {
        let v: f64 = self.get(name, default);
        if !(v.is_finite() && v > 0.0) {
            fail(
                &self.usage,
                &format!("'--{name}' must be a positive number, got {v}"),
            );
        }
        v
    }

    /// Exits 2 with `msg` and the usage.
    pub fn fail(&self, msg: &str) -> ! {
        fail(&self.usage, msg)
    }
}

fn fail(usage: &str, msg: &str) -> ! {
    eprintln!("error: {msg}\n\n{usage}");
    std::process::exit(2);
}

/// Builds the one-line JSON summary printed last on stdout.
#[derive(Default)]
pub struct Json {
    body: String,
}

impl Json {
    fn key(&mut self, k: &str) {
        if !self.body.is_empty() {
            self.body.push(',');
        }
        let _ = write!(self.body, "\"{k}\":");
    }
    /// A number (non-finite values become `null`, which JSON requires).
    pub fn num(mut self, k: &str, v: f64) -> Self {
        self.key(k);
        push_num(&mut self.body, v);
        self
    }
    /// An integer.
    pub fn int(mut self, k: &str, v: u64) -> Self {
        self.key(k);
        let _ = write!(self.body, "{v}");
        self
    }
    /// A string (no escaping needed for the identifiers used here).
    pub fn str(mut self, k: &str, v: &str) -> Self {
        self.key(k);
        let _ = write!(
            self.body,
            "\"{}\"",
            v.replace('\\', "\\\\").replace('"', "\\\"")
        );
        self
    }
    /// An array of numbers.
    pub fn arr(mut self, k: &str, v: &[f64]) -> Self {
        self.key(k);
        self.body.push('[');
        for (i, x) in v.iter().enumerate() {
            if i > 0 {
                self.body.push(',');
            }
            push_num(&mut self.body, *x);
        }
        self.body.push(']');
        self
    }
    /// Prints the object as one line on stdout.
    pub fn print(self) {
        println!("{{{}}}", self.body);
    }
}

fn push_num(s: &mut String, v: f64) {
    if v.is_finite() {
        // `{:?}` keeps every digit needed to round-trip.
        let _ = write!(s, "{v:?}");
    } else {
        s.push_str("null");
    }
}
