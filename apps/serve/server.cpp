#include "apps/serve/server.hpp"

#include "apps/serve/igtl_connection.hpp"
#include "apps/serve/igtl_messages.hpp"
#include "apps/serve/serve_frame.hpp"
#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/user_error.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"

#include <chrono>
#include <condition_variable>
#include <igtlClientSocket.h>
#include <igtlServerSocket.h>
#include <memory>
#include <mutex>
#include <thread>

namespace brainshift::serve {
namespace {

using core::Clock;

/// A volume waiting for the worker.
struct Pending {
  imaging::VolumeF volume;
  std::string name;            ///< device and arrival, for reports ("Doppler #3")
  Clock::time_point received;  ///< when its last byte arrived
};

/// HOST:PORT → (host, port). \throws brainshift::Error naming the text.
std::pair<std::string, int> host_port(const std::string& text) {
  const auto colon = text.rfind(':');
  BS_VERIFY(colon != std::string::npos && colon > 0 && colon + 1 < text.size(),
            "--connect " << text << ": expected HOST:PORT (e.g. localhost:18944)");
  int port = 0;
  try {
    std::size_t used = 0;
    port = std::stoi(text.substr(colon + 1), &used);
    BS_VERIFY(used == text.size() - colon - 1, "");
  } catch (...) {
    port = -1;
  }
  BS_VERIFY(port > 0 && port < 65536, "--connect " << text << ": the port must be 1-65535");
  return {text.substr(0, colon), port};
}

class Server {
 public:
  Server(const ServeOptions& o, const workflow::Progress& progress, const std::atomic<bool>& stop)
      : m_options(o), m_progress(progress), m_stop(stop), m_frames(o, progress) {}

  ServeSummary run() {
    std::thread worker([this] { work(); });
    try {
      if (m_options.listen)
        listen();
      else
        connect();
    } catch (...) {
      finish(worker);
      throw;
    }
    finish(worker);
    return m_summary;
  }

 private:
  void finish(std::thread& worker) {
    {
      const std::lock_guard<std::mutex> lock(m_mutex);
      m_done = true;
    }
    m_wake.notify_all();
    worker.join();
  }

  void listen() {
    auto server = igtl::ServerSocket::New();
    BS_VERIFY(server->CreateServer(*m_options.listen) >= 0,
              "--listen " << *m_options.listen << ": cannot open the port (in use?)");
    m_progress.stage("listening on port " + std::to_string(server->GetServerPort()) +
                     " (OpenIGTLink)");
    while (!m_stop.load()) {
      igtl::ClientSocket::Pointer client = server->WaitForConnection(200);
      if (client.IsNull()) continue;
      m_progress.stage("a client connected");
      talk(client.GetPointer());
      m_progress.stage("client disconnected; listening");
    }
    server->CloseSocket();
  }

  void connect() {
    const auto [host, port] = host_port(m_options.connect);
    bool said = false;
    while (!m_stop.load()) {
      auto client = igtl::ClientSocket::New();
      if (client->ConnectToServer(host.c_str(), port) != 0) {
        if (!said) m_progress.stage("waiting for " + m_options.connect + " (retrying every 2 s)");
        said = true;
        for (int i = 0; i < 10 && !m_stop.load(); ++i)
          std::this_thread::sleep_for(std::chrono::milliseconds(200));
        continue;
      }
      said = false;
      m_progress.stage("connected to " + m_options.connect);
      talk(client.GetPointer());
      m_progress.stage("connection to " + m_options.connect + " lost; reconnecting");
    }
  }

  /// Receives until the peer leaves or the server stops; volumes go to the worker.
  void talk(igtl::Socket* socket) {
    auto c = std::make_shared<Connection>(igtl::Socket::Pointer(socket));
    {
      const std::lock_guard<std::mutex> lock(m_mutex);
      m_connection = c;
    }
    m_frames.set_connection(c);
    auto wanted = [this](const std::string& type, const std::string& device) {
      return type == "IMAGE" &&
             (device == m_options.doppler_device || device == m_options.bmode_device ||
              device == m_options.pre_dura_device);
    };
    while (!m_stop.load() && c->open()) {
      std::optional<Incoming> in = c->receive(m_stop, wanted);
      if (!in) break;
      if (in->ignored) continue;
      if (!in->problem.empty()) {
        refuse(*c, in->problem, in->status_code);
        if (in->fatal) break;
        continue;
      }
      take(*c, *in);
    }
    // Stopping: the frame in progress is finished and answered before the connection closes;
    // what still waits is dropped.
    if (m_stop.load() && c->open()) finish_current();
    c->close();
    m_frames.set_connection(nullptr);
    const std::lock_guard<std::mutex> lock(m_mutex);
    m_connection.reset();
  }

  void refuse(Connection& c, const std::string& problem, int code) {
    ++m_summary.bad_messages;
    logger().warn("{}", problem);
    c.send(status_message(code, 0, "refused", problem, "BrainshiftStatus"));
  }

  /// An IMAGE of a wanted device: checked, converted, queued (the latest of a device wins).
  void take(Connection& c, const Incoming& in) {
    const auto received = in.complete;
    auto& image = *static_cast<igtl::ImageMessage*>(in.message.GetPointer());
    Pending p;
    p.name = in.device + " #" + std::to_string(++m_received);
    p.received = received;
    try {
      p.volume = volume_from_image(image, in.body_bytes, p.name);
    } catch (const std::exception& e) {
      refuse(c, workflow::user_message(e), igtl::StatusMessage::STATUS_CONFIG_ERROR);
      return;
    }
    m_progress.stage("received " + p.name + " (" + std::to_string(p.volume.geometry.size[0]) + "x" +
                     std::to_string(p.volume.geometry.size[1]) + "x" +
                     std::to_string(p.volume.geometry.size[2]) + ")");
    {
      const std::lock_guard<std::mutex> lock(m_mutex);
      if (in.device == m_options.bmode_device) {
        m_bmode = std::make_shared<const Pending>(std::move(p));
        m_bmode_new = true;
      } else {
        std::optional<Pending>& slot =
            in.device == m_options.doppler_device ? m_doppler : m_pre_dura;
        if (slot.has_value())
          m_progress.stage(p.name + " replaces " + slot->name + ", which was still waiting");
        slot = std::move(p);
      }
    }
    m_wake.notify_all();
  }

  /// The worker: pre-dura sweeps first (the frames after them need the pose), then Doppler.
  void work() {
    for (;;) {
      std::optional<Pending> job;
      bool pre_dura = false;
      std::shared_ptr<const Pending> bmode;
      {
        std::unique_lock<std::mutex> lock(m_mutex);
        m_wake.wait(lock, [this] { return m_done || m_pre_dura || m_doppler || m_bmode_new; });
        if (m_done) return;
        if (!m_pre_dura && !m_doppler) {  // only a new B-mode: its footprint, while idle
          m_bmode_new = false;
          bmode = m_bmode;
          m_busy = true;
          lock.unlock();
          m_frames.prepare_footprint(bmode->volume, bmode->name);
          lock.lock();
          m_busy = false;
          m_wake.notify_all();
          continue;
        }
        pre_dura = m_pre_dura.has_value();
        job = std::move(pre_dura ? m_pre_dura : m_doppler);
        (pre_dura ? m_pre_dura : m_doppler).reset();
        bmode = m_bmode;
        if (!pre_dura) m_bmode_new = false;  // the frame extracts it if not done yet
        m_busy = true;
      }
      const bool ok = pre_dura ? m_frames.measure_pose(job->volume, job->name)
                               : m_frames.register_frame(job->volume, job->name,
                                                         bmode.get() ? &bmode->volume : nullptr,
                                                         bmode ? bmode->name : "", job->received);
      {
        const std::lock_guard<std::mutex> lock(m_mutex);
        if (!pre_dura) ++(ok ? m_summary.frames : m_summary.failed);
        m_busy = false;
      }
      m_wake.notify_all();
    }
  }

  /// Drops what waits and returns when the worker has finished the job it is on.
  void finish_current() {
    std::unique_lock<std::mutex> lock(m_mutex);
    for (std::optional<Pending>* waiting : {&m_doppler, &m_pre_dura})
      if (waiting->has_value()) {
        m_progress.stage("stopping: " + (*waiting)->name + " is not registered");
        waiting->reset();
      }
    if (m_busy) m_progress.stage("stopping after the frame in progress");
    m_wake.wait(lock, [this] { return !m_busy; });
  }

  const ServeOptions& m_options;
  const workflow::Progress& m_progress;
  const std::atomic<bool>& m_stop;
  FrameRegistrar m_frames;
  ServeSummary m_summary;
  int m_received = 0;

  std::mutex m_mutex;  // guards what follows
  std::condition_variable m_wake;
  bool m_done = false;
  bool m_busy = false;       ///< the worker is on a job
  bool m_bmode_new = false;  ///< a B-mode arrived whose footprint is not extracted yet
  std::optional<Pending> m_doppler, m_pre_dura;
  std::shared_ptr<const Pending> m_bmode;
  std::shared_ptr<Connection> m_connection;
};

}  // namespace

ServeSummary serve(const ServeOptions& options, const workflow::Progress& progress,
                   const std::atomic<bool>& stop) {
  BS_VERIFY(options.listen.has_value() != !options.connect.empty(),
            "serve: give --listen PORT or --connect HOST:PORT (one of them)");
  if (!options.connect.empty()) host_port(options.connect);  // malformed: say so before loading
  Server server(options, progress, stop);
  return server.run();
}

}  // namespace brainshift::serve
