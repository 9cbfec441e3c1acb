//! String-named options: one macro gives an enum `FromStr` (whose error lists the valid
//! names), `Display`, and serde support through those names, so Python keywords,
//! command-line flags and config files all spell an option the same way.

/// Declares a `Copy` enum whose variants are spelled by the given strings.
///
/// # Examples
/// ```
/// rperc_core::named_enum! {
///     /// How to draw.
///     #[derive(Default)]
///     pub enum Style: "style" {
///         /// Solid lines.
///         #[default]
///         Solid = "solid",
///         /// Dashed lines.
///         Dashed = "dashed",
///     }
/// }
/// assert_eq!("dashed".parse::<Style>().unwrap(), Style::Dashed);
/// assert_eq!(Style::default().to_string(), "solid");
/// let err = "dotted".parse::<Style>().unwrap_err().to_string();
/// assert_eq!(err, "unknown style 'dotted'; expected one of 'solid', 'dashed'");
/// ```
#[macro_export]
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident : $kind:literal {
            $($(#[$vmeta:meta])* $variant:ident = $text:literal),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        $vis enum $name {
            $($(#[$vmeta])* $variant),+
        }

        impl $name {
            /// Every valid name, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($text),+];

            /// The name of this choice.
            pub fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $text),+
                }
            }
        }

        impl ::std::str::FromStr for $name {
            type Err = $crate::CoreError;

            fn from_str(s: &str) -> ::std::result::Result<Self, Self::Err> {
                match s {
                    $($text => Ok(Self::$variant),)+
                    _ => Err($crate::CoreError::UnknownName {
                        kind: $kind,
                        got: s.to_owned(),
                        expected: Self::NAMES,
                    }),
                }
            }
        }

        impl ::std::fmt::Display for $name {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl $crate::serde::Serialize for $name {
            fn serialize<S: $crate::serde::Serializer>(&self, s: S) -> ::std::result::Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }

        // Configs export their schema (field names, types, defaults, doc comments) to
        // the Python layer, which generates its typed config classes from it.
        impl $crate::schemars::JsonSchema for $name {
            fn schema_name() -> ::std::borrow::Cow<'static, str> {
                ::std::borrow::Cow::Borrowed(stringify!($name))
            }

            fn json_schema(_: &mut $crate::schemars::SchemaGenerator) -> $crate::schemars::Schema {
                $crate::schemars::json_schema!({"type": "string", "enum": [$($text),+]})
            }
        }

        impl<'de> $crate::serde::Deserialize<'de> for $name {
            fn deserialize<D: $crate::serde::Deserializer<'de>>(d: D) -> ::std::result::Result<Self, D::Error> {
                let s = <::std::string::String as $crate::serde::Deserialize>::deserialize(d)?;
                s.parse().map_err(<D::Error as $crate::serde::de::Error>::custom)
            }
        }
    };
}
