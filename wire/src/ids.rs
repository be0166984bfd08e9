//! Typed ids: a mission's, a plan's and an obstacle's id are different types, so one
//! cannot be passed where another is meant. On the wire each is a plain string
//! (`#[serde(transparent)]`); they borrow as `&str` for SQL binds and formatting.

use serde::{Deserialize, Serialize};

macro_rules! string_id {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(
            Debug, Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize,
        )]
        #[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
        #[cfg_attr(feature = "openapi", schema(value_type = String))]
        #[serde(transparent)]
        pub struct $name(pub String);

        impl $name {
            /// The id as text.
            pub fn as_str(&self) -> &str {
                &self.0
            }
        }

        impl std::ops::Deref for $name {
            type Target = str;
            fn deref(&self) -> &str {
                &self.0
            }
        }

        impl std::borrow::Borrow<str> for $name {
            fn borrow(&self) -> &str {
                &self.0
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(&self.0)
            }
        }

        impl From<String> for $name {
            fn from(s: String) -> Self {
                Self(s)
            }
        }

        impl From<$name> for String {
            fn from(id: $name) -> String {
                id.0
            }
        }

        impl From<&$name> for String {
            fn from(id: &$name) -> String {
                id.0.clone()
            }
        }

        impl From<&str> for $name {
            fn from(s: &str) -> Self {
                Self(s.to_string())
            }
        }

        impl PartialEq<str> for $name {
            fn eq(&self, other: &str) -> bool {
                self.0 == other
            }
        }

        impl PartialEq<&str> for $name {
            fn eq(&self, other: &&str) -> bool {
                self.0 == *other
            }
        }
    };
}

string_id!(
    /// A stored mission's id.
    MissionId
);
string_id!(
    /// A stored plan's id (unique across missions).
    PlanId
);
string_id!(
    /// A moving or stationary obstacle's id within its mission (interop: its list index).
    ObstacleId
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_plain_strings_on_the_wire() {
        let id = MissionId::from("a1b2");
        assert_eq!(serde_json::to_string(&id).unwrap(), "\"a1b2\"");
        let back: MissionId = serde_json::from_str("\"a1b2\"").unwrap();
        assert_eq!(back, id);
        assert_eq!(back, "a1b2");
        assert_eq!(format!("/api/v1/missions/{id}"), "/api/v1/missions/a1b2");
        assert!(serde_json::from_str::<PlanId>("7").is_err());
    }
}
