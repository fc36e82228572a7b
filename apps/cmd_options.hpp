#pragma once
/// @file
/// @brief `brainshift options`: every scene key with its default, accepted values and one-line
/// documentation (workflow/options_table.hpp). Wiring only.

#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// Arguments of `brainshift options`.
struct OptionsArgs {
  bool markdown = false;  ///< docs/OPTIONS.md instead of one key a line
};

/// Registers the `options` subcommand on `app`, filling `args` on parse. `args` is not owned
/// and must outlive `app`.
CLI::App* add_options_command(CLI::App& app, OptionsArgs& args);

/// Prints the table to `out`. @return 0.
int run_options(const OptionsArgs& args, std::ostream& out);

}  // namespace brainshift::apps
