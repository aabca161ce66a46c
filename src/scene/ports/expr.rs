//! Expressions of time for input signals: `"2 * sin(3 * t) + 0.5 * t^2"`.
//!
//! Grammar: numbers, `t`, `pi`, `+ − * / ^` (right-associative power, binding tighter than a
//! leading minus: `-t^2 = −(t²)`), parentheses, and the functions `sin cos tan exp ln sqrt
//! abs tanh min max`. Parsed once at compile time; evaluation allocates nothing.

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Num(f64),
    Time,
    Neg(Box<Expr>),
    Bin(char, Box<Expr>, Box<Expr>),
    Call(Func, Vec<Expr>),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Func {
    Sin,
    Cos,
    Tan,
    Exp,
    Ln,
    Sqrt,
    Abs,
    Tanh,
    Min,
    Max,
}

impl Func {
    fn named(name: &str) -> Option<(Self, usize)> {
        Some(match name {
            "sin" => (Self::Sin, 1),
            "cos" => (Self::Cos, 1),
            "tan" => (Self::Tan, 1),
            "exp" => (Self::Exp, 1),
            "ln" => (Self::Ln, 1),
            "sqrt" => (Self::Sqrt, 1),
            "abs" => (Self::Abs, 1),
            "tanh" => (Self::Tanh, 1),
            "min" => (Self::Min, 2),
            "max" => (Self::Max, 2),
            _ => return None,
        })
    }
}

impl Expr {
    /// The value at time `t`.
    pub(crate) fn eval(&self, t: f64) -> f64 {
        match self {
            Self::Num(v) => *v,
            Self::Time => t,
            Self::Neg(e) => -e.eval(t),
            Self::Bin(op, a, b) => {
                let (a, b) = (a.eval(t), b.eval(t));
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    '/' => a / b,
                    _ => a.powf(b),
                }
            }
            Self::Call(f, args) => {
                let a = args[0].eval(t);
                match f {
                    Func::Sin => a.sin(),
                    Func::Cos => a.cos(),
                    Func::Tan => a.tan(),
                    Func::Exp => a.exp(),
                    Func::Ln => a.ln(),
                    Func::Sqrt => a.sqrt(),
                    Func::Abs => a.abs(),
                    Func::Tanh => a.tanh(),
                    Func::Min => a.min(args[1].eval(t)),
                    Func::Max => a.max(args[1].eval(t)),
                }
            }
        }
    }

    /// Parses `text`; the error names the column (1-based) and what was expected.
    pub(crate) fn parse(text: &str) -> Result<Self, String> {
        let mut p = Parser {
            s: text.as_bytes(),
            i: 0,
        };
        let e = p.sum()?;
        p.skip();
        if p.i < p.s.len() {
            return Err(p.error("an operator or the end of the expression"));
        }
        Ok(e)
    }
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn skip(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.s.get(self.i).copied()
    }
    fn error(&self, expected: &str) -> String {
        let found = match self.s.get(self.i) {
            Some(&c) => format!("'{}'", c as char),
            None => "the end".to_owned(),
        };
        format!(
            "expression column {}: expected {expected}, found {found}",
            self.i + 1
        )
    }
    fn sum(&mut self) -> Result<Expr, String> {
        let mut e = self.product()?;
        while let Some(op @ (b'+' | b'-')) = self.peek() {
            self.i += 1;
            e = Expr::Bin(op as char, Box::new(e), Box::new(self.product()?));
        }
        Ok(e)
    }
    fn product(&mut self) -> Result<Expr, String> {
        let mut e = self.unary()?;
        while let Some(op @ (b'*' | b'/')) = self.peek() {
            self.i += 1;
            e = Expr::Bin(op as char, Box::new(e), Box::new(self.unary()?));
        }
        Ok(e)
    }
    fn unary(&mut self) -> Result<Expr, String> {
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                Ok(Expr::Neg(Box::new(self.unary()?)))
            }
            Some(b'+') => {
                self.i += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }
    fn power(&mut self) -> Result<Expr, String> {
        let base = self.atom()?;
        if self.peek() == Some(b'^') {
            self.i += 1;
            return Ok(Expr::Bin('^', Box::new(base), Box::new(self.unary()?)));
        }
        Ok(base)
    }
    fn atom(&mut self) -> Result<Expr, String> {
        match self.peek() {
            Some(b'(') => {
                self.i += 1;
                let e = self.sum()?;
                self.expect(b')')?;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => self.number(),
            Some(c) if c.is_ascii_alphabetic() => {
                let start = self.i;
                while self.i < self.s.len() && self.s[self.i].is_ascii_alphanumeric() {
                    self.i += 1;
                }
                let name = std::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
                match name {
                    "t" => return Ok(Expr::Time),
                    "pi" => return Ok(Expr::Num(std::f64::consts::PI)),
                    _ => {}
                }
                let Some((f, arity)) = Func::named(name) else {
                    self.i = start;
                    return Err(self.error(
                        "t, pi, a number or a function (sin cos tan exp ln sqrt abs tanh min max)",
                    ));
                };
                self.expect(b'(')?;
                let mut args = vec![self.sum()?];
                while args.len() < arity {
                    self.expect(b',')?;
                    args.push(self.sum()?);
                }
                self.expect(b')')?;
                Ok(Expr::Call(f, args))
            }
            _ => Err(self.error("a number, t, a function or '('")),
        }
    }
    fn number(&mut self) -> Result<Expr, String> {
        let start = self.i;
        while self.i < self.s.len()
            && (self.s[self.i].is_ascii_digit()
                || self.s[self.i] == b'.'
                || ((self.s[self.i] == b'e' || self.s[self.i] == b'E')
                    && self.i + 1 < self.s.len()
                    && (self.s[self.i + 1].is_ascii_digit()
                        || self.s[self.i + 1] == b'-'
                        || self.s[self.i + 1] == b'+'))
                || ((self.s[self.i] == b'-' || self.s[self.i] == b'+')
                    && self.i > start
                    && (self.s[self.i - 1] == b'e' || self.s[self.i - 1] == b'E')))
        {
            self.i += 1;
        }
        let text = std::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
        text.parse::<f64>().map(Expr::Num).map_err(|_| {
            self.i = start;
            self.error("a number")
        })
    }
    fn expect(&mut self, c: u8) -> Result<(), String> {
        if self.peek() == Some(c) {
            self.i += 1;
            Ok(())
        } else {
            Err(self.error(&format!("'{}'", c as char)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Expr;

    #[test]
    fn expressions_parse_with_the_usual_precedence() {
        let e = |s: &str, t: f64| Expr::parse(s).unwrap().eval(t);
        assert_eq!(e("1 + 2 * 3", 0.0), 7.0);
        assert_eq!(e("-t^2", 3.0), -9.0);
        assert_eq!(e("2^3^2", 0.0), 512.0);
        assert_eq!(e("(1 + t) / 2", 3.0), 2.0);
        assert!((e("2 * sin(3 * t) + 1.5e-1", 0.5) - (2.0 * 1.5f64.sin() + 0.15)).abs() < 1e-15);
        assert_eq!(e("max(t, 2) - min(t, 2)", 5.0), 3.0);
        assert_eq!(e("cos(pi)", 0.0), -1.0);
        let err = Expr::parse("2 * sine(t)").unwrap_err();
        assert!(err.contains("column 5"), "{err}");
        assert!(Expr::parse("(t + 1").unwrap_err().contains("expected ')'"));
        assert!(Expr::parse("t t").unwrap_err().contains("column 3"));
    }
}
