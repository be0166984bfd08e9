//! Wire timestamps: RFC 3339 strings or Unix seconds (numbers), into `f64` Unix seconds.
//! RFC 3339 is parsed and formatted by `jiff`; no input, however malformed, panics.

use serde::{Deserialize, Deserializer, Serialize};

/// A timestamp as the wire carries it: an RFC 3339 string or Unix seconds (a number >= 0).
/// Its OpenAPI schema says exactly that (`oneOf` a `date-time` string or a number >= 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(transparent)]
pub struct WireTime(pub f64);

#[cfg(feature = "openapi")]
impl utoipa::PartialSchema for WireTime {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{
            KnownFormat, ObjectBuilder, OneOfBuilder, SchemaFormat, Type,
        };
        OneOfBuilder::new()
            .item(
                ObjectBuilder::new()
                    .schema_type(Type::String)
                    .format(Some(SchemaFormat::KnownFormat(KnownFormat::DateTime)))
                    // Years 1970 to 9999: Unix seconds are never negative.
                    .pattern(Some(r"^(19[7-9][0-9]|[2-9][0-9]{3})-"))
                    .description(Some("RFC 3339 from 1970 on, e.g. 2026-06-14T15:04:05.25Z")),
            )
            .item(
                ObjectBuilder::new()
                    .schema_type(Type::Number)
                    .minimum(Some(0.0))
                    .description(Some("Unix seconds")),
            )
            .description(Some(
                "A time: an RFC 3339 string or Unix seconds (a number >= 0).",
            ))
            .examples([serde_json::json!("2026-06-14T15:04:05.25Z")])
            .into()
    }
}

#[cfg(feature = "openapi")]
impl utoipa::ToSchema for WireTime {}

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

/// Parses an RFC 3339 timestamp into Unix seconds (by `jiff`, never panics on any input).
///
/// Accepted: `2018-06-14T15:00:00Z`, a numeric offset (`+02:00`), fractional seconds down to
/// nanoseconds, `t`/`z` in lower case. A date-time with no offset at all
/// (`2018-06-14T15:00:00`, also with a space for `T`) is read as UTC, as jink always has.
/// Times before 1970 are refused (the wire's Unix seconds are non-negative).
///
/// # Errors
/// A message naming the bad input.
pub fn parse_rfc3339(s: &str) -> Result<f64, String> {
    let s = s.trim();
    let ts = match s.parse::<jiff::Timestamp>() {
        Ok(ts) => ts,
        Err(with_offset) => s
            .parse::<jiff::civil::DateTime>()
            .ok()
            .and_then(|dt| dt.to_zoned(jiff::tz::TimeZone::UTC).ok())
            .map(|z| z.timestamp())
            .ok_or_else(|| {
                format!("'{s}' is not an RFC 3339 timestamp or Unix seconds: {with_offset}")
            })?,
    };
    if ts < jiff::Timestamp::UNIX_EPOCH {
        return Err(format!("'{s}' is before 1970"));
    }
    Ok(ts.as_second() as f64 + f64::from(ts.subsec_nanosecond()) * 1e-9)
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

/// Formats Unix seconds as RFC 3339 (UTC, microseconds), e.g. `2018-06-14T15:00:00.000000Z`.
/// Negative times format as the epoch; times past the year 9999 as `jiff`'s last instant.
pub fn format_rfc3339(t_s: f64) -> String {
    let t = jiff::Timestamp::from_microsecond(to_us(t_s.max(0.0))).unwrap_or(jiff::Timestamp::MAX);
    t.strftime("%Y-%m-%dT%H:%M:%S%.6fZ").to_string()
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
        assert_eq!(parse_rfc3339("2018-06-14T15:00:00").unwrap(), z);
        assert_eq!(parse_rfc3339("2018-06-14 15:00:00").unwrap(), z);
        assert_eq!(parse_rfc3339("2018-06-14t15:00:00z").unwrap(), z);
        assert_eq!(parse_rfc3339("2018-06-14T10:30:00-04:30").unwrap(), z);
        assert!(parse_rfc3339("1969-12-31T23:59:59Z").is_err());
        assert!(parse_rfc3339("2018-13-14T15:00:00Z").is_err());
        assert!(parse_rfc3339("2018-06-14T15:00:00+26:00").is_err());
    }

    /// The query string of issue 11 that made the hand-written parser panic (`split_at`
    /// inside a multi-byte character): now a plain error.
    #[test]
    fn multi_byte_input_is_an_error_not_a_panic() {
        let raw = "\u{d57c}\u{c1257}";
        assert!(parse_rfc3339(raw).is_err());
        assert!(serde_json::from_value::<WireTime>(serde_json::json!(raw)).is_err());
        assert!(parse_rfc3339("2018-06-14T15:00:00\u{e9}00:00").is_err());
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
        assert_eq!(format_rfc3339(-3.0), "1970-01-01T00:00:00.000000Z");
        assert!(format_rfc3339(1e300).starts_with("9999-12-"));
    }

    /// The schema states what the parser accepts: a `date-time` string or a number >= 0
    /// (the values the parser refuses, negative numbers, are outside it).
    #[cfg(feature = "openapi")]
    #[test]
    fn the_schema_is_a_date_time_string_or_a_non_negative_number() {
        let v = serde_json::to_value(<WireTime as utoipa::PartialSchema>::schema()).unwrap();
        let one_of = v["oneOf"].as_array().unwrap();
        assert_eq!(one_of.len(), 2);
        assert_eq!(one_of[0]["type"], "string");
        assert_eq!(one_of[0]["format"], "date-time");
        assert_eq!(one_of[1]["type"], "number");
        assert_eq!(one_of[1]["minimum"], 0.0);
        let example = v["examples"][0].clone();
        assert!(serde_json::from_value::<WireTime>(example).is_ok());
        assert!(serde_json::from_value::<WireTime>(serde_json::json!(-0.5)).is_err());
    }

    proptest::proptest! {
        /// Any string at all: parsing answers Ok or Err, never panics.
        #[test]
        fn arbitrary_strings_never_panic(s in "\\PC*", raw in proptest::collection::vec(proptest::num::u8::ANY, 0..40)) {
            let _ = parse_rfc3339(&s);
            let _ = serde_json::from_value::<WireTime>(serde_json::json!(s));
            let lossy = String::from_utf8_lossy(&raw);
            let _ = parse_rfc3339(&lossy);
            let _ = serde_json::from_slice::<WireTime>(&raw);
        }

        /// Strings shaped like timestamps, with random digits and offsets: no panic, and an
        /// accepted one means the instant its fields say.
        #[test]
        fn timestamp_shaped_strings_never_panic(
            s in "[0-9]{4}-[0-9]{2}-[0-9]{2}[Tt ][0-9]{2}:[0-9]{2}:[0-9]{2}(\\.[0-9]{1,12})?([Zz]|[+-][0-9]{2}:[0-9]{2})?"
        ) {
            if let Ok(t) = parse_rfc3339(&s) {
                proptest::prop_assert!(t >= 0.0 && t.is_finite());
            }
        }

        /// Formatting then parsing gives back the time to the microsecond, over 1970..2100 (where
        /// an `f64` of Unix seconds still resolves microseconds).
        #[test]
        fn format_then_parse_round_trips(us in 0i64..4_102_444_800_000_000) {
            let t = from_us(us);
            let back = parse_rfc3339(&format_rfc3339(t)).unwrap();
            proptest::prop_assert_eq!(to_us(back), to_us(t));
        }
    }
}
