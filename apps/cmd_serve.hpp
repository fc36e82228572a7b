#pragma once
/// @file
/// @brief `brainshift serve`: registrations over OpenIGTLink (apps/serve/server.hpp), as a server
/// for 3D Slicer (`--listen PORT`, default 18944) or a client of a PLUS server (`--connect
/// HOST:PORT`). Runs until SIGINT or SIGTERM, finishing the frame in progress; exit 0 then.

#include "apps/serve/server.hpp"

#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// The flags of `brainshift serve` (serve/server.hpp).
struct ServeArgs : serve::ServeOptions {
  int listen_port = 18944;
};

CLI::App* add_serve_command(CLI::App& app, ServeArgs& args);
int run_serve(ServeArgs args, std::ostream& out);

}  // namespace brainshift::apps
