#include "server/interfaces.hpp"

#include <fmt/format.h>

#include "server/encode.hpp"

namespace sculpt::server {
namespace {

class SubscriptionImpl final : public proto::Subscription::Server {
 public:
  SubscriptionImpl(server::Server& server, std::uint64_t id) : server_(server), id_(id) {}
  ~SubscriptionImpl() noexcept(false) { server_.remove_stream(id_); }

  kj::Promise<void> setRate(SetRateContext context) override {
    server_.set_rate(id_, context.getParams().getMaxFps());
    return kj::READY_NOW;
  }
  kj::Promise<void> setTolerance(SetToleranceContext context) override {
    server_.set_tolerance(id_, context.getParams().getToleranceM());
    return kj::READY_NOW;
  }

 private:
  server::Server& server_;
  std::uint64_t id_;
};

class ExportReaderImpl final : public proto::ExportReader::Server {
 public:
  ExportReaderImpl(server::Server& server, std::uint64_t id, std::uint64_t client)
      : server_(server), id_(id), client_(client) {}
  ~ExportReaderImpl() noexcept(false) { server_.close_export(id_); }

  kj::Promise<void> read(ReadContext context) override {
    if (!server_.admit(client_))
      return kj::Promise<void>(KJ_EXCEPTION(DISCONNECTED, "over a limit (see the daemon's log): the connection is closing"));
    const auto p = context.getParams();
    server_.read_export(id_, p.getOffset(), p.getCount(), context.getResults());
    return kj::READY_NOW;
  }

 private:
  server::Server& server_;
  std::uint64_t id_, client_;
};

class SessionImpl final : public proto::Session::Server {
 public:
  SessionImpl(server::Server& server, std::uint64_t client) : server_(server), client_(client) {}

  kj::Promise<void> status(StatusContext context) override {
    return answer([&] { server_.fill_status(context.getResults().initStats()); });
  }
  kj::Promise<void> devices(DevicesContext context) override {
    return answer([&] {
      const auto list = server_.control().devices();
      fill_devices(context.getResults().initDevices(static_cast<unsigned>(list.size())), list);
    });
  }
  kj::Promise<void> keyframe(KeyframeContext context) override {
    return answer([&] { server_.fill_keyframe_now(context.getResults(server_.keyframe_size_hint()).initKeyframe()); });
  }
  kj::Promise<void> subscribe(SubscribeContext context) override {
    if (!server_.admit(client_)) return closing();
    auto p = context.getParams();
    const std::uint64_t id = server_.add_stream(p.getViewer(), p.getToleranceM(), p.getMaxFps(), client_);
    context.getResults().setSubscription(kj::heap<SubscriptionImpl>(server_, id));
    return kj::READY_NOW;
  }
  kj::Promise<void> loadScene(LoadSceneContext context) override {
    if (!server_.admit(client_)) return closing();
    const std::string path = context.getParams().getPath();
    return server_.control().load_scene(path).then([context](std::string error) mutable {
      fill(context.getResults().initResult(), error);
    });
  }
  kj::Promise<void> reset(ResetContext context) override {
    if (!server_.admit(client_)) return closing();
    return server_.control().reset().then([context](std::string error) mutable {
      fill(context.getResults().initResult(), error);
    });
  }
  kj::Promise<void> pause(PauseContext context) override {
    if (!server_.admit(client_)) return closing();
    const std::string error = server_.control().set_paused(true);
    if (!error.empty()) return result(context.getResults().initResult(), error);
    return answer_when_paused(context.getResults().initResult(), true);
  }
  kj::Promise<void> resume(ResumeContext context) override {
    if (!server_.admit(client_)) return closing();
    const std::string error = server_.control().set_paused(false);
    if (!error.empty()) return result(context.getResults().initResult(), error);
    return answer_when_paused(context.getResults().initResult(), false);
  }
  kj::Promise<void> undo(UndoContext context) override { return move_history(context, false); }
  kj::Promise<void> redo(RedoContext context) override { return move_history(context, true); }
  kj::Promise<void> history(HistoryContext context) override {
    const auto p = context.getParams();
    return answer([&] { server_.fill_history(context.getResults().initHistory(), p.getFrom(), p.getLimit()); });
  }
  kj::Promise<void> exportSculpt(ExportSculptContext context) override {
    if (!server_.admit(client_)) return closing();
    if (const std::string why = server_.export_refusal(client_); !why.empty())
      return result(context.getResults().initResult(), why);
    std::uint64_t id = 0;
    auto landed = server_.start_export(client_, id);
    // After the answer, or when the call is cancelled.
    auto release = kj::defer([&server = server_, id] { server.release_export(id); });
    return landed
        .then([this, context, id]() mutable {
          auto r = context.getResults();
          std::uint64_t size = 0;
          const std::string error = server_.open_export(id, size);
          fill(r.initResult(), error);
          if (!error.empty()) return;
          r.setSize(size);
          r.setReader(make_export_reader(server_, id, client_));
        })
        .attach(kj::mv(release));
  }
  kj::Promise<void> tuneHaptics(TuneHapticsContext context) override {
    return answer([&] {
      const auto p = context.getParams();
      HapticsTune tune;
      if (p.getSetGain()) tune.gain = p.getGain();
      if (p.getSetLimit()) tune.limit = p.getLimit();
      const HapticsTuneOutcome out = server_.control().tune_haptics(p.getSlot(), tune);
      auto r = context.getResults();
      fill(r.initResult(), out.error);
      r.setGain(static_cast<float>(out.gain));
      r.setLimit(static_cast<float>(out.limit));
    });
  }

 private:
  // A call answered at once, unless the client is being closed.
  template <class Fill>
  kj::Promise<void> answer(Fill fill) {
    if (!server_.admit(client_)) return closing();
    fill();
    return kj::READY_NOW;
  }
  // ok only once the sim thread has obeyed: a stalled or finished one never does,
  // and a keyframe taken after pause() answers ok must be the final state.
  kj::Promise<void> answer_when_paused(proto::Result::Builder r, bool paused) {
    return server_.until_paused(paused).then([r, paused](bool obeyed) mutable {
      r.setOk(obeyed);
      if (!obeyed)
        r.setError(paused ? "the simulation thread did not pause within 2 s (stalled or finished)"
                          : "the simulation thread did not resume within 2 s (stalled or finished)");
    });
  }
  template <class Context>
  kj::Promise<void> move_history(Context context, bool redo) {
    if (!server_.admit(client_)) return closing();
    const std::uint32_t count = context.getParams().getCount();
    if (const std::string why = server_.history_move_refusal(client_, count); !why.empty())
      return result(context.getResults().initResult(), why);
    return server_.move_history(client_, redo, count).then([context](HistoryMoveOutcome o) mutable {
      auto r = context.getResults();
      fill(r.initResult(), o.error);
      r.setDone(o.done);
      r.setTick(o.tick);
    });
  }
  // A client over a limit gets no more answers: it is being disconnected.
  static kj::Promise<void> closing() {
    return kj::Promise<void>(KJ_EXCEPTION(DISCONNECTED, "over a limit (see the daemon's log): the connection is closing"));
  }
  static void fill(proto::Result::Builder r, const std::string& error) {
    r.setOk(error.empty());
    r.setError(error);
  }
  static kj::Promise<void> result(proto::Result::Builder r, const std::string& error) {
    fill(r, error);
    return kj::READY_NOW;
  }
  server::Server& server_;
  std::uint64_t client_;
};

class SculptdImpl final : public proto::Sculptd::Server {
 public:
  SculptdImpl(server::Server& server, std::uint64_t client, std::string peer)
      : server_(server), client_(client), peer_(std::move(peer)) {}

  kj::Promise<void> hello(HelloContext context) override {
    auto p = context.getParams();
    auto r = context.getResults();
    r.setMajor(proto::PROTOCOL_MAJOR);
    r.setMinor(proto::PROTOCOL_MINOR);
    r.setServer(server_.options().name);
    const std::string who = p.getClient();
    server_.said_hello(client_, who);
    if (const std::string refusal = server_.refusal(client_); !refusal.empty()) {
      r.setAccepted(false);
      r.setReason(refusal);
      return kj::READY_NOW;
    }
    if (p.getMajor() != proto::PROTOCOL_MAJOR) {
      const std::string reason = fmt::format("this daemon speaks protocol {}.{}, the client {}.{}; no major but {} "
                                             "is understood",
                                             proto::PROTOCOL_MAJOR, proto::PROTOCOL_MINOR, p.getMajor(),
                                             p.getMinor(), proto::PROTOCOL_MAJOR);
      r.setAccepted(false);
      r.setReason(reason);
      if (server_.options().log)
        server_.options().log(5, fmt::format("client {} ({}, \"{}\") refused: {}", client_, peer_, who, reason));
      return kj::READY_NOW;
    }
    r.setAccepted(true);
    r.setSession(kj::heap<SessionImpl>(server_, client_));
    if (server_.options().log)
      server_.options().log(7, fmt::format("client {} ({}) is \"{}\", protocol {}.{}", client_, peer_, who,
                                           p.getMajor(), p.getMinor()));
    return kj::READY_NOW;
  }

 private:
  server::Server& server_;
  std::uint64_t client_;
  std::string peer_;
};

}  // namespace

kj::Own<proto::Sculptd::Server> make_sculptd(Server& server, std::uint64_t client, std::string peer) {
  return kj::heap<SculptdImpl>(server, client, std::move(peer));
}

proto::ExportReader::Client make_export_reader(Server& server, std::uint64_t id, std::uint64_t client) {
  return kj::heap<ExportReaderImpl>(server, id, client);
}

}  // namespace sculpt::server
