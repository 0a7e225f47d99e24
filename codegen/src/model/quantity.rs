//! Quantities written in a model file: numbers with units (`30 g`, `1.7e-7 kg m^2`) and
//! arithmetic on numbers and parameters (`shin_mass * shin_length^2 / 12`, `sin(120 deg)`).
//!
//! A small recursive-descent grammar over the text of one YAML scalar. Every error carries the
//! character offset of the faulty token inside the scalar, which the loader turns into a line
//! and column. Evaluation tracks the dimension of each intermediate (kg, m, s, A and rad) so
//! that a field can refuse a unit of the wrong kind, and builds the polynomial in the tunable
//! parameters for the fields that keep them symbolic.
//!
//! Grammar (lowest precedence first; `^` binds tighter than unary minus and is
//! right-associative, as in mathematics: `-2^2 = -4`, `2^3^2 = 2^9`):
//!
//! ```text
//! sum     = product (("+" | "-") product)*
//! product = unary (("*" | "/") unary)*
//! unary   = ("-" | "+") unary | power
//! power   = primary ("^" unary)?
//! primary = NUMBER unit? | NAME "(" sum ("," sum)* ")" | NAME | "(" sum ")"
//! unit    = UNIT ("^" INTEGER)? (("/")? UNIT ("^" INTEGER)?)*
//! ```
//!
//! A unit follows a number directly (`30 g`, `0.13 N m`, `9.81 m/s^2`); a name after a
//! number is a unit only if it is one of [`UNITS`], so a parameter is multiplied with `*`.

use crate::sym::poly::Poly;

/// Exponents of kg, m, s, A and rad.
pub type Dim = [i8; 5];

/// A dimensionless number.
pub const ONE: Dim = [0, 0, 0, 0, 0];
/// The dimension of a parameter given as a plain number: SI units of some dimension the file
/// does not say. It combines with anything, and any field accepts a result that involves it.
pub const UNKNOWN: Dim = [i8::MIN, 0, 0, 0, 0];
/// kg.
pub const MASS: Dim = [1, 0, 0, 0, 0];
/// m.
pub const LENGTH: Dim = [0, 1, 0, 0, 0];
/// A.
pub const CURRENT: Dim = [0, 0, 0, 1, 0];
/// rad.
pub const ANGLE: Dim = [0, 0, 0, 0, 1];
/// s⁻¹.
pub const FREQUENCY: Dim = [0, 0, -1, 0, 0];
/// N = kg·m·s⁻².
pub const FORCE: Dim = [1, 1, -2, 0, 0];
/// N·m.
pub const TORQUE: Dim = [1, 2, -2, 0, 0];
/// kg·m².
pub const INERTIA: Dim = [1, 2, 0, 0, 0];
/// m·s⁻².
pub const ACCELERATION: Dim = [0, 1, -2, 0, 0];
/// V = kg·m²·s⁻³·A⁻¹.
pub const VOLTAGE: Dim = [1, 2, -3, -1, 0];
/// Ω = kg·m²·s⁻³·A⁻².
pub const RESISTANCE: Dim = [1, 2, -3, -2, 0];
/// H = kg·m²·s⁻²·A⁻².
pub const INDUCTANCE: Dim = [1, 2, -2, -2, 0];
/// N·m/A.
pub const TORQUE_CONSTANT: Dim = [1, 2, -2, -1, 0];
/// N·m/A per rad (V·s/rad, the same constant as a back-EMF constant).
pub const TORQUE_CONSTANT_PER_RAD: Dim = [1, 2, -2, -1, -1];
/// N·m·s (rotary damping).
pub const ROTARY_DAMPING: Dim = [1, 2, -1, 0, 0];
/// N·m·s/rad.
pub const ROTARY_DAMPING_PER_RAD: Dim = [1, 2, -1, 0, -1];
/// N·s/m.
pub const LINEAR_DAMPING: Dim = [1, 0, -1, 0, 0];
/// N/m.
pub const STIFFNESS: Dim = [1, 0, -2, 0, 0];

/// A unit: its name, its factor to SI as a power of ten times a remaining factor (a decimal
/// prefix shifts the literal's exponent instead of multiplying, so `37.2 mm` is the same
/// number as `0.0372`), and its dimension.
pub struct Unit {
    /// The unit as written.
    pub name: &'static str,
    /// The power of ten of its factor to SI.
    pub decimal: i32,
    /// The rest of its factor to SI.
    pub factor: f64,
    /// Its dimension.
    pub dim: Dim,
}

const fn unit(name: &'static str, decimal: i32, factor: f64, dim: Dim) -> Unit {
    Unit { name, decimal, factor, dim }
}

const PI: f64 = std::f64::consts::PI;

/// The units a number may carry.
pub const UNITS: &[Unit] = &[
    unit("kg", 0, 1.0, MASS),
    unit("g", -3, 1.0, MASS),
    unit("mg", -6, 1.0, MASS),
    unit("m", 0, 1.0, LENGTH),
    unit("cm", -2, 1.0, LENGTH),
    unit("mm", -3, 1.0, LENGTH),
    unit("um", -6, 1.0, LENGTH),
    unit("s", 0, 1.0, [0, 0, 1, 0, 0]),
    unit("ms", -3, 1.0, [0, 0, 1, 0, 0]),
    unit("us", -6, 1.0, [0, 0, 1, 0, 0]),
    unit("min", 0, 60.0, [0, 0, 1, 0, 0]),
    unit("A", 0, 1.0, CURRENT),
    unit("mA", -3, 1.0, CURRENT),
    unit("rad", 0, 1.0, ANGLE),
    unit("deg", 0, PI / 180.0, ANGLE),
    unit("rev", 0, 2.0 * PI, ANGLE),
    unit("Hz", 0, 1.0, FREQUENCY),
    unit("kHz", 3, 1.0, FREQUENCY),
    unit("rpm", 0, 2.0 * PI / 60.0, [0, 0, -1, 0, 1]),
    unit("N", 0, 1.0, FORCE),
    unit("mN", -3, 1.0, FORCE),
    unit("Nm", 0, 1.0, TORQUE),
    unit("mNm", -3, 1.0, TORQUE),
    unit("V", 0, 1.0, VOLTAGE),
    unit("mV", -3, 1.0, VOLTAGE),
    unit("ohm", 0, 1.0, RESISTANCE),
    unit("Ω", 0, 1.0, RESISTANCE),
    unit("mohm", -3, 1.0, RESISTANCE),
    unit("H", 0, 1.0, INDUCTANCE),
    unit("mH", -3, 1.0, INDUCTANCE),
    unit("uH", -6, 1.0, INDUCTANCE),
];

/// The functions an expression may call, with their number of arguments.
pub const FUNCTIONS: &[(&str, usize)] = &[
    ("sin", 1),
    ("cos", 1),
    ("tan", 1),
    ("asin", 1),
    ("acos", 1),
    ("atan", 1),
    ("atan2", 2),
    ("sqrt", 1),
    ("abs", 1),
];

/// Names of the derived dimensions a model file uses.
const NAMED: &[(Dim, &str)] = &[
    (FREQUENCY, "Hz"),
    (FORCE, "N"),
    (TORQUE, "N·m"),
    (VOLTAGE, "V"),
    (RESISTANCE, "Ω"),
    (INDUCTANCE, "H"),
    (TORQUE_CONSTANT, "N·m/A"),
    (TORQUE_CONSTANT_PER_RAD, "N·m/(A·rad)"),
    (ROTARY_DAMPING, "N·m·s"),
    (ROTARY_DAMPING_PER_RAD, "N·m·s/rad"),
    (LINEAR_DAMPING, "N·s/m"),
    (STIFFNESS, "N/m"),
    (ACCELERATION, "m/s^2"),
];

/// The dimension in words: `N·m`, `kg·m^2`, `dimensionless`.
pub fn dim_name(dim: Dim) -> String {
    if let Some((_, name)) = NAMED.iter().find(|(d, _)| *d == dim) {
        return (*name).to_string();
    }
    const BASE: [&str; 5] = ["kg", "m", "s", "A", "rad"];
    let parts: Vec<String> = dim
        .iter()
        .zip(BASE)
        .filter(|(e, _)| **e != 0)
        .map(|(e, b)| if *e == 1 { b.to_string() } else { format!("{b}^{e}") })
        .collect();
    if parts.is_empty() {
        "dimensionless".into()
    } else {
        parts.join("·")
    }
}

/// A failure inside one scalar: the character offset of the faulty token and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct ExprError {
    /// Offset, in characters, of the faulty token from the start of the scalar.
    pub offset: usize,
    /// What is wrong.
    pub message: String,
    /// How to fix it.
    pub hint: Option<String>,
}

fn fail<T>(offset: usize, message: impl Into<String>) -> Result<T, ExprError> {
    Err(ExprError { offset, message: message.into(), hint: None })
}

#[derive(Clone, Debug, PartialEq)]
enum Token {
    /// A number literal, as written.
    Number(String),
    Name(String),
    Op(char),
}

fn tokenize(text: &str) -> Result<Vec<(Token, usize)>, ExprError> {
    let chars: Vec<char> = text.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let start = i;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit())) {
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            // An exponent: `e` followed by digits (with a sign); `e` alone starts a name.
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    while j < chars.len() && chars[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            let literal: String = chars[start..i].iter().collect();
            if literal.matches('.').count() > 1 {
                return fail(start, format!("`{literal}` is not a number"));
            }
            tokens.push((Token::Number(literal), start));
        } else if c.is_alphabetic() || c == '_' {
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            tokens.push((Token::Name(chars[start..i].iter().collect()), start));
        } else if "+-*/^(),".contains(c) {
            tokens.push((Token::Op(c), start));
            i += 1;
        } else {
            return Err(ExprError {
                offset: start,
                message: format!("unexpected character `{c}`"),
                hint: Some("an expression has numbers with units, parameter names, + - * / ^, parentheses and functions".into()),
            });
        }
    }
    Ok(tokens)
}

/// A parsed expression; offsets locate errors found while evaluating.
#[derive(Clone, Debug, PartialEq)]
enum Expr {
    /// A literal with its unit: the SI value, its dimension, and where the unit is (if any).
    Number {
        value: f64,
        dim: Dim,
        unit_at: Option<usize>,
    },
    Name {
        name: String,
        at: usize,
    },
    Negate(Box<Expr>),
    Binary {
        op: char,
        at: usize,
        left: Box<Expr>,
        right: Box<Expr>,
    },
    Call {
        name: String,
        at: usize,
        args: Vec<Expr>,
    },
}

struct Parser {
    tokens: Vec<(Token, usize)>,
    next: usize,
    /// Offset just past the text, for "expected ... at the end".
    end: usize,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.next).map(|(t, _)| t)
    }

    fn offset(&self) -> usize {
        self.tokens.get(self.next).map_or(self.end, |(_, at)| *at)
    }

    fn eat(&mut self, op: char) -> bool {
        if self.peek() == Some(&Token::Op(op)) {
            self.next += 1;
            true
        } else {
            false
        }
    }

    fn sum(&mut self) -> Result<Expr, ExprError> {
        let mut left = self.product()?;
        while let Some(Token::Op(op @ ('+' | '-'))) = self.peek().cloned() {
            let at = self.offset();
            self.next += 1;
            let right = self.product()?;
            left = Expr::Binary { op, at, left: Box::new(left), right: Box::new(right) };
        }
        Ok(left)
    }

    fn product(&mut self) -> Result<Expr, ExprError> {
        let mut left = self.unary()?;
        while let Some(Token::Op(op @ ('*' | '/'))) = self.peek().cloned() {
            let at = self.offset();
            self.next += 1;
            let right = self.unary()?;
            left = Expr::Binary { op, at, left: Box::new(left), right: Box::new(right) };
        }
        Ok(left)
    }

    fn unary(&mut self) -> Result<Expr, ExprError> {
        if self.eat('-') {
            return Ok(Expr::Negate(Box::new(self.unary()?)));
        }
        if self.eat('+') {
            return self.unary();
        }
        self.power()
    }

    fn power(&mut self) -> Result<Expr, ExprError> {
        let base = self.primary()?;
        let at = self.offset();
        if self.eat('^') {
            let exponent = self.unary()?;
            return Ok(Expr::Binary { op: '^', at, left: Box::new(base), right: Box::new(exponent) });
        }
        Ok(base)
    }

    fn primary(&mut self) -> Result<Expr, ExprError> {
        let at = self.offset();
        match self.peek().cloned() {
            Some(Token::Number(literal)) => {
                self.next += 1;
                self.number(&literal, at)
            }
            Some(Token::Name(name)) => {
                self.next += 1;
                if self.eat('(') {
                    let mut args = vec![self.sum()?];
                    while self.eat(',') {
                        args.push(self.sum()?);
                    }
                    if !self.eat(')') {
                        return fail(self.offset(), format!("expected `,` or `)` in the call of `{name}`"));
                    }
                    return Ok(Expr::Call { name, at, args });
                }
                Ok(Expr::Name { name, at })
            }
            Some(Token::Op('(')) => {
                self.next += 1;
                let inner = self.sum()?;
                if !self.eat(')') {
                    return fail(self.offset(), "expected `)`");
                }
                Ok(inner)
            }
            Some(Token::Op(c)) => fail(at, format!("expected a number, a name or `(`, got `{c}`")),
            None => fail(at, "expected a number, a name or `(` at the end"),
        }
    }

    /// A literal and the unit after it.
    fn number(&mut self, literal: &str, at: usize) -> Result<Expr, ExprError> {
        let (mut decimal, mut factor, mut dim) = (0i32, 1.0f64, ONE);
        let mut unit_at = None;
        let mut divide = false;
        loop {
            // A unit name, or `/` then a unit name.
            let (name, name_at, consumed) = match (self.peek().cloned(), self.tokens.get(self.next + 1)) {
                (Some(Token::Name(n)), _) if find_unit(&n).is_some() => (n, self.offset(), 1),
                (Some(Token::Op('/')), Some((Token::Name(n), n_at)))
                    if unit_at.is_some() && find_unit(n).is_some() =>
                {
                    divide = true;
                    (n.clone(), *n_at, 2)
                }
                _ => break,
            };
            self.next += consumed;
            let Some(u) = find_unit(&name) else { break };
            unit_at.get_or_insert(name_at);
            let mut exponent: i32 = 1;
            if self.peek() == Some(&Token::Op('^')) {
                let negative = self.tokens.get(self.next + 1).map(|(t, _)| t) == Some(&Token::Op('-'));
                let digits_at = self.next + 1 + usize::from(negative);
                if let Some((Token::Number(n), n_at)) = self.tokens.get(digits_at) {
                    let Ok(e) = n.parse::<i32>() else {
                        return fail(*n_at, format!("a unit's power is a whole number, got `{n}`"));
                    };
                    if e > 8 {
                        return fail(*n_at, format!("a unit's power is at most 8, got {e}"));
                    }
                    exponent = if negative { -e } else { e };
                    self.next = digits_at + 1;
                }
            }
            if divide {
                exponent = -exponent;
            }
            decimal += u.decimal * exponent;
            factor *= u.factor.powi(exponent);
            for (d, ud) in dim.iter_mut().zip(u.dim) {
                *d += ud * exponent as i8;
            }
        }
        // The decimal part of the unit shifts the literal's own exponent: `37.2 mm` is read as
        // `37.2e-3`, the same number as the literal `0.0372`.
        let (mantissa, exponent) = match literal.find(['e', 'E']) {
            Some(i) => (&literal[..i], literal[i + 1..].parse::<i32>().unwrap_or(0)),
            None => (literal, 0),
        };
        let shifted = format!("{mantissa}e{}", exponent + decimal);
        let Ok(mut value) = shifted.parse::<f64>() else {
            return fail(at, format!("`{literal}` is not a number"));
        };
        if factor != 1.0 {
            value *= factor;
        }
        if !value.is_finite() {
            return fail(at, format!("`{literal}` is out of range"));
        }
        Ok(Expr::Number { value, dim, unit_at })
    }
}

fn find_unit(name: &str) -> Option<&'static Unit> {
    UNITS.iter().find(|u| u.name == name)
}

/// A parsed expression.
#[derive(Clone, Debug, PartialEq)]
pub struct Expression(Expr);

/// Parses the text of one scalar.
pub fn parse(text: &str) -> Result<Expression, ExprError> {
    let tokens = tokenize(text)?;
    let end = text.chars().count();
    let mut parser = Parser { tokens, next: 0, end };
    if parser.tokens.is_empty() {
        return fail(0, "expected a number or an expression, got nothing");
    }
    let expr = parser.sum()?;
    if parser.next < parser.tokens.len() {
        let at = parser.offset();
        let what = match &parser.tokens[parser.next].0 {
            Token::Name(n) if matches!(expr, Expr::Number { .. }) => {
                return Err(ExprError {
                    offset: at,
                    message: format!("unknown unit `{n}`"),
                    hint: Some(format!(
                        "units: {}; multiply a parameter with `*`",
                        UNITS.iter().map(|u| u.name).collect::<Vec<_>>().join(", ")
                    )),
                })
            }
            Token::Name(n) | Token::Number(n) => format!("`{n}`"),
            Token::Op(c) => format!("`{c}`"),
        };
        return fail(at, format!("unexpected {what} after a complete expression"));
    }
    Ok(Expression(expr))
}

/// What a name stands for during evaluation.
#[derive(Clone, Debug)]
pub struct Operand {
    /// Its nominal value, SI.
    pub value: f64,
    /// Its dimension (that of the parameter's value; plain numbers are dimensionless).
    pub dim: Dim,
    /// The polynomial, for a tunable parameter; `None` for a constant.
    pub poly: Option<Poly>,
}

/// The value of an expression: its nominal number, dimension, and the polynomial in the
/// tunable parameters if it depends on any.
#[derive(Clone, Debug)]
pub struct Quantity {
    /// The nominal value, SI.
    pub value: f64,
    /// The dimension.
    pub dim: Dim,
    /// The polynomial in the tunable parameters; `None` for a constant.
    pub poly: Option<Poly>,
    /// Where the first tunable parameter it depends on is written, and its name.
    pub tunable_at: Option<(usize, String)>,
    /// Where the first unit is written (where a dimension error points).
    pub unit_at: Option<usize>,
}

impl Quantity {
    fn constant(value: f64, dim: Dim) -> Self {
        Quantity { value, dim, poly: None, tunable_at: None, unit_at: None }
    }

    fn polynomial(&self) -> Poly {
        self.poly.clone().unwrap_or_else(|| Poly::constant(self.value))
    }
}

/// The largest power a tunable parameter may be raised to.
const MAX_POLY_POWER: f64 = 16.0;

impl Expression {
    /// Evaluates with `lookup` for names (`pi` is built in).
    pub fn eval(&self, lookup: &dyn Fn(&str) -> Option<Operand>) -> Result<Quantity, ExprError> {
        eval(&self.0, lookup)
    }

    /// The parameter names it uses (not `pi`), with their offsets, in the order written.
    pub fn names(&self) -> Vec<(String, usize)> {
        fn collect(e: &Expr, out: &mut Vec<(String, usize)>) {
            match e {
                Expr::Number { .. } => {}
                Expr::Name { name, at } => {
                    if name != "pi" {
                        out.push((name.clone(), *at));
                    }
                }
                Expr::Negate(inner) => collect(inner, out),
                Expr::Binary { left, right, .. } => {
                    collect(left, out);
                    collect(right, out);
                }
                Expr::Call { args, .. } => args.iter().for_each(|a| collect(a, out)),
            }
        }
        let mut out = Vec::new();
        collect(&self.0, &mut out);
        out
    }

    /// The name, if the expression is a bare name.
    pub fn bare_name(&self) -> Option<&str> {
        match &self.0 {
            Expr::Name { name, .. } => Some(name),
            _ => None,
        }
    }
}

fn first_at(a: &Option<(usize, String)>, b: &Option<(usize, String)>) -> Option<(usize, String)> {
    a.clone().or_else(|| b.clone())
}

fn eval(expr: &Expr, lookup: &dyn Fn(&str) -> Option<Operand>) -> Result<Quantity, ExprError> {
    match expr {
        Expr::Number { value, dim, unit_at } => {
            Ok(Quantity { value: *value, dim: *dim, poly: None, tunable_at: None, unit_at: *unit_at })
        }
        Expr::Name { name, at } => {
            if name == "pi" {
                return Ok(Quantity::constant(PI, ONE));
            }
            match lookup(name) {
                Some(o) => {
                    let tunable_at = o.poly.as_ref().map(|_| (*at, name.clone()));
                    Ok(Quantity { value: o.value, dim: o.dim, poly: o.poly, tunable_at, unit_at: None })
                }
                None if find_unit(name).is_some() => Err(ExprError {
                    offset: *at,
                    message: format!("unknown parameter `{name}`"),
                    hint: Some(format!("a unit follows a number: `1 {name}`")),
                }),
                None => fail(*at, format!("unknown parameter `{name}`")),
            }
        }
        Expr::Negate(inner) => {
            let mut q = eval(inner, lookup)?;
            q.value = -q.value;
            q.poly = q.poly.map(|p| p.scale(-1.0));
            Ok(q)
        }
        Expr::Binary { op, at, left, right } => {
            let (a, b) = (eval(left, lookup)?, eval(right, lookup)?);
            let tunable_at = first_at(&a.tunable_at, &b.tunable_at);
            let unit_at = a.unit_at.or(b.unit_at);
            let symbolic = a.poly.is_some() || b.poly.is_some();
            let (value, dim, poly) = match op {
                '+' | '-' => {
                    // A dimensionless term is a plain number in SI units: it takes the other's.
                    let dim = if a.dim == UNKNOWN || b.dim == UNKNOWN {
                        UNKNOWN
                    } else if a.dim == ONE {
                        b.dim
                    } else if b.dim == ONE || a.dim == b.dim {
                        a.dim
                    } else {
                        return fail(
                            *at,
                            format!(
                                "cannot {} {} and {}",
                                if *op == '+' { "add" } else { "subtract" },
                                dim_name(a.dim),
                                dim_name(b.dim)
                            ),
                        );
                    };
                    let poly = symbolic.then(|| {
                        if *op == '+' {
                            a.polynomial().add(&b.polynomial())
                        } else {
                            a.polynomial().sub(&b.polynomial())
                        }
                    });
                    (if *op == '+' { a.value + b.value } else { a.value - b.value }, dim, poly)
                }
                '*' => {
                    let dim =
                        if a.dim == UNKNOWN || b.dim == UNKNOWN { UNKNOWN } else { combine(a.dim, b.dim, 1) };
                    (a.value * b.value, dim, symbolic.then(|| a.polynomial().mul(&b.polynomial())))
                }
                '/' => {
                    if let Some((t_at, name)) = &b.tunable_at {
                        return Err(ExprError {
                            offset: *t_at,
                            message: format!("the tunable parameter `{name}` cannot divide"),
                            hint: Some(
                                "a tunable parameter enters the generated code as a polynomial".into(),
                            ),
                        });
                    }
                    if b.value == 0.0 {
                        return fail(*at, "division by zero");
                    }
                    let dim = if a.dim == UNKNOWN || b.dim == UNKNOWN {
                        UNKNOWN
                    } else {
                        combine(a.dim, b.dim, -1)
                    };
                    (a.value / b.value, dim, a.poly.as_ref().map(|p| p.scale(1.0 / b.value)))
                }
                _ => {
                    if let Some((t_at, name)) = &b.tunable_at {
                        return Err(ExprError {
                            offset: *t_at,
                            message: format!("the tunable parameter `{name}` cannot be a power"),
                            hint: Some(
                                "a tunable parameter enters the generated code as a polynomial".into(),
                            ),
                        });
                    }
                    if b.dim != ONE && b.dim != UNKNOWN {
                        return fail(*at, format!("a power must be dimensionless, got {}", dim_name(b.dim)));
                    }
                    let n = b.value;
                    let whole = n.fract() == 0.0 && n.abs() <= 127.0;
                    if a.dim != ONE && a.dim != UNKNOWN && !whole {
                        return fail(
                            *at,
                            format!(
                                "a quantity with a unit ({}) needs a whole power, got {n}",
                                dim_name(a.dim)
                            ),
                        );
                    }
                    let dim = if a.dim == ONE || a.dim == UNKNOWN {
                        a.dim
                    } else {
                        scaled(a.dim, n as i32).ok_or_else(|| ExprError {
                            offset: *at,
                            message: "the power's unit is too large".into(),
                            hint: None,
                        })?
                    };
                    let poly = match &a.poly {
                        Some(p) => {
                            if !(whole && (0.0..=MAX_POLY_POWER).contains(&n)) {
                                let (t_at, name) = a.tunable_at.clone().unwrap_or((*at, String::new()));
                                return Err(ExprError {
                                    offset: t_at,
                                    message: format!("the tunable parameter `{name}` may only be raised to a whole power from 0 to {MAX_POLY_POWER}, got {n}"),
                                    hint: Some("a tunable parameter enters the generated code as a polynomial".into()),
                                });
                            }
                            let mut acc = Poly::constant(1.0);
                            for _ in 0..n as u32 {
                                acc = acc.mul(p);
                            }
                            Some(acc)
                        }
                        None => None,
                    };
                    (a.value.powf(n), dim, poly)
                }
            };
            if !value.is_finite() {
                return fail(*at, format!("the result of `{op}` is not a finite number"));
            }
            Ok(Quantity { value, dim, poly, tunable_at, unit_at })
        }
        Expr::Call { name, at, args } => {
            let Some(&(_, arity)) = FUNCTIONS.iter().find(|(f, _)| f == name) else {
                return Err(ExprError {
                    offset: *at,
                    message: format!("unknown function `{name}`"),
                    hint: Some(format!(
                        "functions: {}",
                        FUNCTIONS.iter().map(|(f, _)| *f).collect::<Vec<_>>().join(", ")
                    )),
                });
            };
            if args.len() != arity {
                return fail(
                    *at,
                    format!(
                        "`{name}` takes {arity} argument{}, got {}",
                        if arity == 1 { "" } else { "s" },
                        args.len()
                    ),
                );
            }
            let values = args.iter().map(|a| eval(a, lookup)).collect::<Result<Vec<_>, _>>()?;
            if let Some((t_at, p)) = values.iter().find_map(|q| q.tunable_at.clone()) {
                return Err(ExprError {
                    offset: t_at,
                    message: format!("the tunable parameter `{p}` cannot be used inside `{name}`"),
                    hint: Some("a tunable parameter enters the generated code as a polynomial: use it with + - * and whole powers only".into()),
                });
            }
            let x = &values[0];
            let angle_or_one = |q: &Quantity| q.dim == ONE || q.dim == ANGLE || q.dim == UNKNOWN;
            let (value, dim) = match name.as_str() {
                "sin" | "cos" | "tan" => {
                    if !angle_or_one(x) {
                        return fail(*at, format!("`{name}` takes an angle, got {}", dim_name(x.dim)));
                    }
                    let v = match name.as_str() {
                        "sin" => x.value.sin(),
                        "cos" => x.value.cos(),
                        _ => x.value.tan(),
                    };
                    (v, ONE)
                }
                "asin" | "acos" | "atan" => {
                    if x.dim != ONE && x.dim != UNKNOWN {
                        return fail(
                            *at,
                            format!("`{name}` takes a dimensionless number, got {}", dim_name(x.dim)),
                        );
                    }
                    let v = match name.as_str() {
                        "asin" => x.value.asin(),
                        "acos" => x.value.acos(),
                        _ => x.value.atan(),
                    };
                    (v, ANGLE)
                }
                "atan2" => {
                    let y = &values[1];
                    let loose = |d: Dim| d == ONE || d == UNKNOWN;
                    if x.dim != y.dim && !loose(x.dim) && !loose(y.dim) {
                        return fail(
                            *at,
                            format!(
                                "`atan2` takes two numbers of one unit, got {} and {}",
                                dim_name(x.dim),
                                dim_name(y.dim)
                            ),
                        );
                    }
                    (x.value.atan2(y.value), ANGLE)
                }
                "sqrt" => {
                    if x.dim != UNKNOWN && x.dim.iter().any(|e| e % 2 != 0) {
                        return fail(*at, format!("`sqrt` of {} has no unit", dim_name(x.dim)));
                    }
                    (x.value.sqrt(), if x.dim == UNKNOWN { UNKNOWN } else { x.dim.map(|e| e / 2) })
                }
                _ => (x.value.abs(), x.dim),
            };
            if !value.is_finite() {
                return fail(*at, format!("`{name}` of {} is not a finite number", x.value));
            }
            let unit_at = values.iter().find_map(|q| q.unit_at);
            Ok(Quantity { value, dim, poly: None, tunable_at: None, unit_at })
        }
    }
}

fn combine(a: Dim, b: Dim, sign: i8) -> Dim {
    let mut d = a;
    for (x, y) in d.iter_mut().zip(b) {
        *x = x.saturating_add(sign.saturating_mul(y));
    }
    d
}

fn scaled(a: Dim, n: i32) -> Option<Dim> {
    let mut d = a;
    for x in d.iter_mut() {
        *x = i8::try_from(i32::from(*x) * n).ok()?;
    }
    Some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(text: &str) -> f64 {
        parse(text)
            .and_then(|e| e.eval(&|_| None))
            .map(|q| q.value)
            .unwrap_or_else(|e| panic!("{text}: {e:?}"))
    }

    fn quantity(text: &str) -> Quantity {
        parse(text).and_then(|e| e.eval(&|_| None)).unwrap_or_else(|e| panic!("{text}: {e:?}"))
    }

    fn error(text: &str) -> ExprError {
        match parse(text).and_then(|e| {
            e.eval(&|name| {
                (name == "t").then(|| Operand { value: 2.0, dim: ONE, poly: Some(Poly::constant(2.0)) })
            })
        }) {
            Ok(q) => panic!("{text} evaluated to {}", q.value),
            Err(e) => e,
        }
    }

    #[test]
    fn precedence_and_associativity() {
        assert_eq!(value("2^3^2"), 512.0);
        assert_eq!(value("-2^2"), -4.0);
        assert_eq!(value("2^-1"), 0.5);
        assert_eq!(value("1 - 2 - 3"), -4.0);
        assert_eq!(value("12 / 3 / 2"), 2.0);
        assert_eq!(value("1 + 2 * 3"), 7.0);
        assert_eq!(value("(1 + 2) * 3"), 9.0);
        assert_eq!(value("-(1 + 2)"), -3.0);
        assert_eq!(value("sqrt(3)/2 * 4"), 3f64.sqrt() / 2.0 * 4.0);
        assert_eq!(value("atan2(1, 1)"), std::f64::consts::FRAC_PI_4);
        assert_eq!(value("pi"), PI);
    }

    #[test]
    fn units_convert_to_si() {
        assert_eq!(value("30 g"), 0.03);
        assert_eq!(value("37.2 mm"), 0.0372);
        assert_eq!(value("1.7e-7 kg m^2"), 1.7e-7);
        assert_eq!(value("17 g cm^2"), 1.7e-6);
        assert_eq!(value("0.13 N m"), 0.13);
        assert_eq!(value("2.1 ohm"), 2.1);
        assert_eq!(value("1 mH"), 0.001);
        assert_eq!(value("700 Hz"), 700.0);
        assert_eq!(value("7.5 kHz"), 7500.0);
        assert_eq!(value("180 deg"), PI);
        assert_eq!(value("60 rpm"), 2.0 * PI);
        assert_eq!(value("25.5 mNm/A"), 0.0255);
        assert_eq!(quantity("9.81 m/s^2").dim, ACCELERATION);
        assert_eq!(quantity("0.13 N m").dim, TORQUE);
        assert_eq!(quantity("0.02 N m / A").dim, TORQUE_CONSTANT);
        assert_eq!(quantity("2.1 Ω").dim, RESISTANCE);
        assert_eq!(quantity("30 mm / 2").value, 0.015);
        assert_eq!(quantity("30 mm / 2").dim, LENGTH);
    }

    #[test]
    fn dimensions_are_checked() {
        assert!(error("3 mm + 2 g").message.contains("cannot add m and kg"));
        assert!(error("sin(3 mm)").message.contains("takes an angle"));
        assert!(error("sqrt(3 mm)").message.contains("no unit"));
        assert!(error("2 ^ (1 mm)").message.contains("dimensionless"));
        assert_eq!(quantity("sqrt(4 mm^2)").dim, LENGTH);
        assert_eq!(quantity("asin(1)").dim, ANGLE);
        assert_eq!(quantity("(2 mm)^2").dim, [0, 2, 0, 0, 0]);
        // A parameter given as a plain number has no known dimension: it mixes with anything.
        let plain = |_: &str| Some(Operand { value: 0.06, dim: UNKNOWN, poly: None });
        let q = parse("20 g * l^2 / 12").and_then(|e| e.eval(&plain)).unwrap();
        assert_eq!(q.dim, UNKNOWN);
        assert_eq!(parse("l + 3 mm").and_then(|e| e.eval(&plain)).unwrap().dim, UNKNOWN);
    }

    #[test]
    fn errors_point_at_the_token() {
        let e = error("1 + foo * 2");
        assert_eq!((e.offset, e.message.as_str()), (4, "unknown parameter `foo`"));
        assert_eq!(error("1 + frob(2)").offset, 4);
        assert_eq!(error("3 parsecs").offset, 2);
        assert_eq!(error("1 / (2 - 2)").offset, 2);
        assert_eq!(error("2 $ 3").offset, 2);
        assert_eq!(error("(1 + 2").offset, 6);
        assert_eq!(error("1e308 * 10").offset, 6);
        let e = error("3 * sin(t)");
        assert_eq!((e.offset, e.message.contains("tunable")), (8, true));
        assert_eq!(error("1 / t").offset, 4);
        assert_eq!(error("t^0.5").offset, 0);
    }

    #[test]
    fn tunable_parameters_stay_polynomial() {
        use crate::sym::poly::Atom;
        let t = Poly::atom(Atom::Param(0));
        let lookup =
            |name: &str| (name == "t").then(|| Operand { value: 3.0, dim: ONE, poly: Some(t.clone()) });
        let q = parse("t * 2^2 / 12 - (t + 1)^2").and_then(|e| e.eval(&lookup)).unwrap();
        let expected = t.scale(4.0 / 12.0).sub(&t.mul(&t).add(&t.scale(2.0)).add(&Poly::constant(1.0)));
        let difference = q.poly.unwrap().sub(&expected);
        assert!(difference.terms().all(|(_, c)| c.abs() < 1e-15), "{difference:?}");
        assert_eq!(q.value, 3.0 * 4.0 / 12.0 - 16.0);
    }

    #[test]
    fn names_skip_units_and_functions() {
        let e = parse("2 * a + sin(30 deg) * b^2 / 1.5e-3 mm + 3 s + pi").unwrap();
        assert_eq!(e.names(), vec![("a".to_string(), 4), ("b".to_string(), 22)]);
    }
}
