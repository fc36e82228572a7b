#include "cmd_options.hpp"

#include "apps/workflow/options_table.hpp"

#include <CLI/CLI.hpp>

#include <ostream>

namespace brainshift::apps {

CLI::App* add_options_command(CLI::App& app, OptionsArgs& args) {
  CLI::App* c = app.add_subcommand(
      "options", "every scene key: path, default, accepted values, what it does (one a line)");
  c->add_flag("--markdown", args.markdown, "print docs/OPTIONS.md (Markdown tables) instead");
  return c;
}

int run_options(const OptionsArgs& args, std::ostream& out) {
  out << (args.markdown ? workflow::options_markdown() : workflow::options_text());
  return 0;
}

}  // namespace brainshift::apps
