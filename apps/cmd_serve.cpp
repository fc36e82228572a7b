#include "cmd_serve.hpp"

#include "apps/workflow/progress.hpp"

#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <iostream>
#include <pthread.h>
#include <thread>

namespace brainshift::apps {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void request_stop(int /*signal*/) { g_stop = true; }

/// SIGINT and SIGTERM set g_stop. They are blocked in the threads of the server (this thread and
/// those it starts) and taken by a thread of their own (sigwait), so that no system call of the
/// server is interrupted half-way (libopenigtlink reports an interrupted select() as an error);
/// the handler covers threads started before (e.g. the BLAS pool). SIGUSR1 ends the thread.
class StopOnSignal {
 public:
  StopOnSignal() {
    struct sigaction action {};
    action.sa_handler = request_stop;
    action.sa_flags = SA_RESTART;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
    sigemptyset(&m_set);
    for (int s : {SIGINT, SIGTERM, SIGUSR1}) sigaddset(&m_set, s);
    pthread_sigmask(SIG_BLOCK, &m_set, nullptr);
    m_thread = std::thread([this] {
      int signal = 0;
      sigwait(&m_set, &signal);
      if (signal != SIGUSR1) g_stop = true;
    });
  }
  ~StopOnSignal() {
    pthread_kill(m_thread.native_handle(), SIGUSR1);
    m_thread.join();
  }
  StopOnSignal(const StopOnSignal&) = delete;
  StopOnSignal& operator=(const StopOnSignal&) = delete;

 private:
  sigset_t m_set{};
  std::thread m_thread;
};

}  // namespace

CLI::App* add_serve_command(CLI::App& app, ServeArgs& args) {
  CLI::App* c = app.add_subcommand(
      "serve", "Register over OpenIGTLink: a server for 3D Slicer or a client of PLUS");
  c->add_option("--model", args.model, "MODEL folder from brainshift prepare")->required();
  c->add_option("--mri", args.mri,
                "pre-operative MRI to warp and send back as IMAGE WarpedMRI (model's grid)");
  c->add_option("--pre-dura-pose", args.pre_dura_pose,
                "navigation offset measured beforehand (brainshift pre-dura); a PreDuraDoppler "
                "volume received later replaces it");
  c->add_option("--out", args.out,
                "folder DIR: DIR/frame_NNNN/ per registration (as register's RES), "
                "DIR/received/ (replayable), DIR/pre_dura_pose.json")
      ->required();
  auto* listen = c->add_option("--listen", args.listen_port,
                               "listen on PORT for 3D Slicer (OpenIGTLinkIF client connector); "
                               "0 picks a free port (printed)")
                     ->expected(0, 1)
                     ->default_str("18944");
  c->add_option("--connect", args.connect,
                "connect to a PLUS server (or any OpenIGTLink server) at HOST:PORT")
      ->excludes(listen);
  c->add_option("--doppler-device", args.doppler_device,
                "IMAGE device name of the power-Doppler volumes (PLUS: e.g. RecVol_Reference)")
      ->capture_default_str();
  c->add_option("--bmode-device", args.bmode_device, "IMAGE device name of the B-mode volumes")
      ->capture_default_str();
  c->add_option("--pre-dura-device", args.pre_dura_device,
                "IMAGE device name of the pre-dura power-Doppler sweep")
      ->capture_default_str();
  return c;
}

int run_serve(ServeArgs args, std::ostream& out) {
  if (args.connect.empty()) args.listen = args.listen_port;
  std::signal(SIGPIPE, SIG_IGN);  // a client that leaves is a closed connection, not a crash
  const StopOnSignal signals;     // before the server's threads start (they inherit the mask)
  const workflow::Progress progress("serve");
  const serve::ServeSummary s = serve::serve(args, progress, g_stop);
  out << "served " << s.frames << " registrations (" << s.failed << " volumes refused, "
      << s.bad_messages << " bad messages); results in " << args.out.string() << "\n";
  return 0;
}

}  // namespace brainshift::apps
