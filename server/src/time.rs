//! Wire timestamps: RFC 3339 strings or Unix seconds (numbers), into `f64` Unix seconds.

use serde::{Deserialize, Deserializer, Serialize};
use utoipa::ToSchema;

/// A timestamp as the wire carries it: an RFC 3339 string or Unix seconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, ToSchema)]
#[serde(transparent)]
#[schema(value_type = serde_json::Value, example = "2026-06-14T15:04:05.25Z")]
pub struct WireTime(pub f64);

impl<'de> Deserialize<'de> for WireTime {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Num(f64),
            Str(String),
        }
        match Raw::deserialize(d)? {
            Raw::Num(s) if s.is_finite() && s >= 0.0 => Ok(WireTime(s)),
            Raw::Num(s) => Err(serde::de::Error::custom(format!(
                "timestamp {s} is not a non-negative Unix time in seconds"
            ))),
            // Query strings carry numbers as text.
            Raw::Str(s) => match s.trim().parse::<f64>() {
                Ok(v) if v.is_finite() && v >= 0.0 => Ok(WireTime(v)),
                Ok(v) => Err(serde::de::Error::custom(format!(
                    "timestamp {v} is not a non-negative Unix time in seconds"
                ))),
                Err(_) => parse_rfc3339(&s)
                    .map(WireTime)
                    .map_err(serde::de::Error::custom),
            },
        }
    }
}

/// Parses an RFC 3339 timestamp into Unix seconds.
///
/// # Errors
/// A message naming the bad input.
pub fn parse_rfc3339(s: &str) -> Result<f64, String> {
    // humantime handles the `Z` form; normalise numeric offsets ourselves.
    let s = s.trim();
    let (base, offset_s) = split_offset(s)?;
    let t = humantime::parse_rfc3339_weak(base)
        .map_err(|e| format!("'{s}' is not an RFC 3339 timestamp or Unix seconds: {e}"))?;
    let d = t
        .duration_since(std::time::UNIX_EPOCH)
        .map_err(|_| format!("'{s}' is before 1970"))?;
    Ok(d.as_secs_f64() - offset_s)
}

fn split_offset(s: &str) -> Result<(&str, f64), String> {
    if let Some(b) = s.strip_suffix('Z').or_else(|| s.strip_suffix('z')) {
        return Ok((b, 0.0));
    }
    // A trailing +HH:MM / -HH:MM after the time part.
    if s.len() > 6 {
        let (head, tail) = s.split_at(s.len() - 6);
        let bytes = tail.as_bytes();
        if (bytes[0] == b'+' || bytes[0] == b'-') && bytes[3] == b':' && head.contains('T') {
            let h: f64 = tail[1..3]
                .parse()
                .map_err(|_| format!("bad offset in '{s}'"))?;
            let m: f64 = tail[4..6]
                .parse()
                .map_err(|_| format!("bad offset in '{s}'"))?;
            let sign = if bytes[0] == b'+' { 1.0 } else { -1.0 };
            return Ok((head, sign * (h * 3600.0 + m * 60.0)));
        }
    }
    Ok((s, 0.0))
}

/// Now, in Unix seconds.
pub fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// Unix seconds to whole microseconds, the storage key of a timestamp.
pub fn to_us(t_s: f64) -> i64 {
    (t_s * 1e6).round() as i64
}

/// Whole microseconds back to Unix seconds.
pub fn from_us(t_us: i64) -> f64 {
    t_us as f64 / 1e6
}

/// Formats Unix seconds as RFC 3339 (UTC, microseconds).
pub fn format_rfc3339(t_s: f64) -> String {
    let t = std::time::UNIX_EPOCH + std::time::Duration::from_micros(to_us(t_s.max(0.0)) as u64);
    humantime::format_rfc3339_micros(t).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_with_zulu_and_offsets_agree() {
        let z = parse_rfc3339("2018-06-14T15:00:00Z").unwrap();
        let plus = parse_rfc3339("2018-06-14T17:00:00+02:00").unwrap();
        let frac = parse_rfc3339("2018-06-14T15:00:00.25Z").unwrap();
        assert_eq!(z, 1_528_988_400.0);
        assert_eq!(plus, z);
        assert!((frac - z - 0.25).abs() < 1e-6);
    }

    #[test]
    fn numbers_and_strings_both_deserialize() {
        let a: WireTime = serde_json::from_str("1528988400.5").unwrap();
        let b: WireTime = serde_json::from_str("\"2018-06-14T15:00:00.5Z\"").unwrap();
        assert_eq!(a, b);
        assert!(serde_json::from_str::<WireTime>("\"yesterday\"").is_err());
        assert!(serde_json::from_str::<WireTime>("-5").is_err());
        let c: WireTime = serde_json::from_str("\"1528988400.5\"").unwrap();
        assert_eq!(a, c);
    }

    #[test]
    fn microsecond_keys_round_trip() {
        assert_eq!(to_us(1.000_001), 1_000_001);
        assert_eq!(from_us(to_us(1528988400.25)), 1528988400.25);
        assert_eq!(
            format_rfc3339(1_528_988_400.0),
            "2018-06-14T15:00:00.000000Z"
        );
    }
}
