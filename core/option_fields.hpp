#pragma once
/// @file
/// @brief The vocabulary of option tables. Every Options struct of the
/// registration has, next to it, a function
///
///     template <class V> void visit_fields(SomeOptions& o, V&& v);
///
/// that calls `v(name, o.member, ...)` once per option: that call is the single source of the
/// option's name in files, its range and its one-line documentation (the default is the member's
/// initialiser). Readers and writers of files (apps/workflow/options_json.hpp) are visitors; this
/// layer knows nothing of JSON. The calls a visitor must accept:
///
///     v(name, double& | int&, Range{lo, hi}, doc)   a number in [lo, hi] (unit: the name's suffix,
///                                                   _mm, _deg, _mib, ...)
///     v(name, bool&, doc)                           true / false
///     v(name, Enum&, doc)                           one of the names of enum_names(Enum{})
///     v(name, Vector3d&, doc)                       three finite numbers
///     v(name, EnumFlag<E>, doc)                     an enum of two values spelled true / false
///     v(name, MebiBytes, Range{lo, hi}, doc)        a byte count spelled in MiB
///     v.nest(prefix, sub)                           visit_fields(sub, v), every name of sub
///                                                   prefixed with `prefix` ("filter.vessels.")
///
/// Names are paths: "a.b" is key b of the object a. Enums: one table of names per enum,
/// `enum_names(E)` (found by argument-dependent lookup), used by to_string / from_string here,
/// by files, reports and the command line.

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace brainshift::core {

/// Closed range [lo, hi] of a numeric option, in the unit its name states.
struct Range {
  double lo = 0.0;
  double hi = 0.0;
};

/// One enum value and how files, reports and the command line spell it.
template <class E>
struct EnumName {
  E value;
  std::string_view name;
};

/// An enum option of two values spelled as a boolean in files (true: `on`, false: `off`).
template <class E>
struct EnumFlag {
  E& value;
  E on;
  E off;
};

/// A byte count spelled in MiB in files (1 MiB = 2^20 bytes).
struct MebiBytes {
  std::size_t& bytes;
};

/// The name of `value` in `table` (an array of EnumName), or "?" when it has none.
template <class Table, class E>
[[nodiscard]] constexpr std::string_view enum_name(const Table& table, E value) {
  for (const auto& n : table)
    if (n.value == value) return n.name;
  return "?";
}

/// The name of an enum value from its table `enum_names(E{})`.
template <class E>
[[nodiscard]] std::string enum_to_string(E value) {
  return std::string(enum_name(enum_names(E{}), value));
}

/// The value spelled `name` in `enum_names(E{})`, or nullopt.
template <class E>
[[nodiscard]] std::optional<E> enum_from_string(std::string_view name) {
  for (const auto& n : enum_names(E{}))
    if (n.name == name) return n.value;
  return std::nullopt;
}

}  // namespace brainshift::core
