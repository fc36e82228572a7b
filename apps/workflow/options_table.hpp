#pragma once
/// @file
/// @brief The scene keys as a table for people: `brainshift options` (one key a line) and
/// docs/OPTIONS.md (`brainshift options --markdown`), both generated from the option tables
/// (`visit_fields` next to each Options struct) with the library's defaults, so that neither can
/// drift from what the scene reader accepts. Units: those the names state (mm, deg, MiB, mN).

#include <string>
#include <vector>

namespace brainshift::workflow {

/// One scene key as printed: its dotted path, default (JSON), accepted values and one-line doc.
struct OptionRow {
  std::string path;
  std::string default_value;
  std::string range;  ///< "[lo, hi]", "true|false", the enum's names "a|b", or "[x, y, z]"
  std::string doc;
};

/// Every scene key, in the order of the option tables, with the library's default.
std::vector<OptionRow> option_rows();

/// `brainshift options`: one key a line, `path  default  range  doc`, columns aligned.
std::string options_text();

/// docs/OPTIONS.md: the same rows as Markdown tables, one per group.
std::string options_markdown();

}  // namespace brainshift::workflow
