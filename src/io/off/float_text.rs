//! Float text: Rust's shortest round-trip digits and Python's `repr(float)`,
//! shared by the OFF and OBJ writers.

/// The shortest decimal digits that parse back to exactly `x` (Rust's
/// shortest round-trip algorithm), printed positionally (`{}`: `0.1`, `100`,
/// `-2.5`) when 1e-5 ≤ |x| < 1e16 or x = 0, else in exponent form (`{:e}`:
/// `1e-7`, `3.4028235e38`) so that no number is longer than 17
/// characters. Non-finite values print as `inf`, `-inf`, `NaN`.
pub fn format_f32_shortest(x: f32) -> String {
    let mut s = String::with_capacity(16);
    push_f32_shortest(&mut s, x);
    s
}

/// [`format_f32_shortest`] appending to `out`.
pub fn push_f32_shortest(out: &mut String, x: f32) {
    use std::fmt::Write as _;
    let a = x.abs();
    // Writing into a String cannot fail.
    let _ = if x == 0.0 || !x.is_finite() || (1e-5..1e16).contains(&a) {
        write!(out, "{x}")
    } else {
        write!(out, "{x:e}")
    };
}

/// Formats `x` exactly as Python 3's `repr(float)` does: the shortest digits
/// that round-trip, positional when the decimal exponent `e` (of
/// `d.ddd × 10^e`) satisfies −4 ≤ e < 16, always with a fractional part
/// (`1.0`, `-0.0`, `100.0`, `0.0001`); otherwise exponent form with the
/// exponent signed and at least two digits (`1e-05`, `1.5e+16`,
/// `1.2345678901234568e+17`). Non-finite values print as `inf`, `-inf`, `nan`.
pub fn python_float_repr(x: f64) -> String {
    let mut out = String::with_capacity(24);
    python_float_repr_into(x, &mut out);
    out
}

/// [`python_float_repr`] appending to `out` (no allocation when `out` has
/// room).
pub fn python_float_repr_into(x: f64, out: &mut String) {
    use std::fmt::Write as _;
    if x.is_nan() {
        out.push_str("nan");
        return;
    }
    if x.is_infinite() {
        out.push_str(if x > 0.0 { "inf" } else { "-inf" });
        return;
    }
    // `{:e}` gives the shortest round-trip digits as `[-]d[.ddd]e[-]N`.
    let start = out.len();
    // Writing into a String cannot fail.
    let _ = write!(out, "{x:e}");
    let (mut digits, mut n, mut exp) = split_sci(&out[start..]);
    // When two strings of that length round-trip because `x` lies exactly
    // halfway between them, Python (David Gay's dtoa) takes the even one
    // and Rust may take the other: redo those with the correctly rounded
    // (ties-to-even) value at that many significant digits.
    if is_decimal_tie(x, n) {
        out.truncate(start);
        let _ = write!(out, "{x:.*e}", n - 1);
        (digits, n, exp) = split_sci(&out[start..]);
        while n > 1 && digits[n - 1] == b'0' {
            n -= 1;
        }
    }
    out.truncate(start);
    let digits = &digits[..n];
    // The digits are ASCII, so this never falls back.
    let digits = std::str::from_utf8(digits).unwrap_or("0");
    if x.is_sign_negative() {
        out.push('-');
    }
    if (-4..16).contains(&exp) {
        if exp >= 0 {
            let int_len = exp as usize + 1;
            if n <= int_len {
                out.push_str(digits);
                out.extend(std::iter::repeat_n('0', int_len - n));
                out.push_str(".0");
            } else {
                out.push_str(&digits[..int_len]);
                out.push('.');
                out.push_str(&digits[int_len..]);
            }
        } else {
            out.push_str("0.");
            out.extend(std::iter::repeat_n('0', (-exp - 1) as usize));
            out.push_str(digits);
        }
    } else {
        out.push_str(&digits[..1]);
        if n > 1 {
            out.push('.');
            out.push_str(&digits[1..]);
        }
        let _ = write!(
            out,
            "e{}{:02}",
            if exp < 0 { '-' } else { '+' },
            exp.unsigned_abs()
        );
    }
}

/// Splits Rust's `[-]d[.ddd]e[-]N` into (digits, digit count, exponent).
fn split_sci(s: &str) -> ([u8; 40], usize, i32) {
    let s = s.strip_prefix('-').unwrap_or(s);
    let (mant, exp) = s.split_once('e').unwrap_or((s, "0"));
    let mut digits = [b'0'; 40];
    let mut n = 0;
    for b in mant.bytes().filter(u8::is_ascii_digit) {
        if n < digits.len() {
            digits[n] = b;
            n += 1;
        }
    }
    (digits, n.max(1), exp.parse().unwrap_or(0))
}

/// True when the exact decimal expansion of `x` (finite, non-zero) has
/// exactly `n + 1` significant digits, the last a 5: `x` is then halfway
/// between two `n`-digit decimals. Every finite double is `m · 2^q` (`m`
/// odd), whose expansion is the integer `m · 5^-q` shifted (q < 0) or
/// `m · 2^q` (q ≥ 0).
fn is_decimal_tie(x: f64, n: usize) -> bool {
    let bits = x.abs().to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1 << 52) - 1);
    let (m, q) = if biased == 0 {
        (frac, -1074)
    } else {
        (frac | (1 << 52), biased - 1075)
    };
    if m == 0 {
        return false;
    }
    let tz = m.trailing_zeros();
    let (m, q) = (m >> tz, q + tz as i32);
    let v = if q < 0 {
        // Beyond 5^55 the product exceeds u128: over 38 significant digits,
        // never a tie at n ≤ 17.
        let k = (-q) as u32;
        if k > 55 {
            return false;
        }
        match u128::from(m).checked_mul(5u128.pow(k)) {
            Some(v) => v,
            None => return false,
        }
    } else if q < 75 {
        let mut v = u128::from(m) << q;
        while v % 10 == 0 {
            v /= 10;
        }
        v
    } else {
        // Too large for u128; rare enough to always take the exact path.
        return true;
    };
    // n + 1 significant digits: 10^n ≤ v < 10^(n+1), and the last is a 5.
    n < 38 && v >= 10u128.pow(n as u32) && (n == 37 || v < 10u128.pow(n as u32 + 1)) && v % 10 == 5
}
