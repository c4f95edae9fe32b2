//! Byte counts on the command line (`--max-memory 512M`).

/// Parses a byte count: a number with an optional suffix K, M, G or T (powers of 1024).
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let (digits, scale) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let scale: u64 = match c.to_ascii_uppercase() {
                'K' => 1 << 10,
                'M' => 1 << 20,
                'G' => 1 << 30,
                'T' => 1 << 40,
                _ => return Err(format!("'{s}': unknown unit (use K, M, G or T)")),
            };
            (&t[..i], scale)
        }
        _ => (t, 1),
    };
    let n: u64 = digits
        .parse()
        .map_err(|_| format!("'{s}' is not a byte count (e.g. 512M, 4G)"))?;
    let bytes = n
        .checked_mul(scale)
        .ok_or_else(|| format!("'{s}' is too large"))?;
    if bytes < 1 << 20 {
        return Err(format!("'{s}': at least 1M is needed"));
    }
    Ok(bytes)
}

/// Parses `--max-memory`: a byte count ([`parse_bytes`]) of at most half the process's
/// address-space limit (`ulimit -v`), when there is one: a larger budget would let an
/// allocation fail (an abort) instead of the limit's message.
pub fn parse_budget(s: &str) -> Result<u64, String> {
    let bytes = parse_bytes(s)?;
    within_address_space(s, bytes, address_space_limit())
}

/// The process's address-space limit (`RLIMIT_AS`), read from `/proc/self/limits`.
pub fn address_space_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line.split_whitespace().nth(3)?.parse().ok()
}

fn within_address_space(s: &str, bytes: u64, limit: Option<u64>) -> Result<u64, String> {
    match limit {
        Some(limit) if bytes > limit / 2 => Err(format!(
            "'{s}' is more than half of the address space this process may use (ulimit -v: {} MiB); at most {}M",
            limit >> 20,
            (limit / 2) >> 20
        )),
        _ => Ok(bytes),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts() {
        assert_eq!(parse_bytes("512M"), Ok(512 << 20));
        assert_eq!(parse_bytes("4g"), Ok(4 << 30));
        assert_eq!(parse_bytes("2097152"), Ok(2 << 20));
        assert!(parse_bytes("12").unwrap_err().contains("at least"));
        assert!(parse_bytes("1X").unwrap_err().contains("unit"));
        assert!(parse_bytes("-1G").is_err());
        assert!(parse_bytes("99999999999T")
            .unwrap_err()
            .contains("too large"));
        assert_eq!(within_address_space("1G", 1 << 30, None), Ok(1 << 30));
        assert_eq!(
            within_address_space("1G", 1 << 30, Some(2 << 30)),
            Ok(1 << 30)
        );
        let e = within_address_space("1T", 1 << 40, Some(1 << 30)).unwrap_err();
        assert!(
            e.contains("ulimit -v: 1024 MiB") && e.contains("at most 512M"),
            "{e}"
        );
    }
}
