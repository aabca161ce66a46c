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
            let flag = format!("--{name} {value}");
            let _ = writeln!(usage, "  {flag:<20} {help}");
        }
        let _ = writeln!(usage, "  {:<20} print this help", "--help");
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

/// Prints `error: …` to stderr and exits 1 (a failure of the run, not of the command line).
pub fn fatal(e: &dyn std::fmt::Display) -> ! {
    eprintln!("error: {e}");
    std::process::exit(1);
}

/// The composition table for `--scheme NAME`: `None` for `base` (the plain second-order
/// scheme), the table for a known table name, exit 2 otherwise.
pub fn scheme_table(
    args: &Args,
    scheme: &str,
    base: &str,
) -> Option<&'static lieflow::flow::CompositionTable> {
    if scheme == base {
        return None;
    }
    match lieflow::flow::coefficients::table_by_name(scheme) {
        Some(t) => Some(t),
        None => args.fail(&format!("unknown scheme '{scheme}'")),
    }
}

/// The number of steps of size `dt` to reach `t_end` (at least 1; exits 2 otherwise).
pub fn steps(args: &Args, dt: f64, t_end: f64) -> usize {
    let steps = (t_end / dt).round();
    if steps < 1.0 {
        args.fail("--t-end must be at least --dt");
    }
    steps as usize
}

/// Times `steps` steps of `flow` from `x0` with nothing observed: nanoseconds per step.
pub fn time_steps<V, F>(flow: &mut F, x0: &V, dt: V::Real, steps: usize) -> f64
where
    V: lieflow::Vector,
    F: lieflow::Flow<V> + ?Sized,
{
    let mut x = x0.clone();
    let start = std::time::Instant::now();
    for k in 0..steps {
        if let Err(e) = flow.step(dt, &mut x) {
            fatal(&format!("step {k}: {e}"));
        }
    }
    start.elapsed().as_nanos() as f64 / steps as f64
}
