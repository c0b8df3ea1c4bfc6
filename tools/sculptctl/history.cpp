// `sculptctl undo [N] | redo [N] [--json]` and `sculptctl history [--from
// NUMBER] [--limit N] [--json]`: the running daemon's strokes (protocol 1.5;
// pages 1.7). undo/redo print what was done ("undid 2 strokes at tick
// 12345"); a refusal (nothing to undo, a stroke made before a scene load) is
// the daemon's error on stderr and exit 1. history lists one page: the
// newest 100 strokes unless asked otherwise.
#include <algorithm>
#include <iostream>
#include <string>
#include <string_view>
#include <vector>

#include <capnp/message.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "daemon_link.hpp"

namespace sculpt::ctl {
namespace {

constexpr std::uint16_t kHistoryMinor = 5;  // Session.undo, redo, history, exportSculpt
constexpr std::uint16_t kPagedHistoryMinor = 7;  // history's from and limit

// 1023 B, 17.8 KiB, 256 MiB: three figures at most.
std::string bytes_text(std::uint64_t b) {
  if (b < 1024) return fmt::format("{} B", b);
  const char* units[] = {"KiB", "MiB", "GiB", "TiB"};
  double v = static_cast<double>(b) / 1024;
  int u = 0;
  while (v >= 1024 && u < 3) v /= 1024, ++u;
  return v < 100 ? fmt::format("{:.1f} {}", v, units[u]) : fmt::format("{:.0f} {}", v, units[u]);
}

std::string strokes(std::uint64_t n) {
  return n == 0 ? std::string("no strokes") : fmt::format("{} stroke{}", n, n == 1 ? "" : "s");
}

std::string tools_text(capnp::List<std::uint32_t>::Reader tools) {
  std::string out;
  for (const auto t : tools) out += (out.empty() ? "" : ",") + std::to_string(t);
  return out.empty() ? "-" : out;
}

// What a daemon of minor 5 or 6 (no total, no newer) says, as a page.
struct PageCounts {
  std::uint64_t total = 0, older = 0, newer = 0;
};
PageCounts counts_of(proto::History::Reader h) {
  const std::uint64_t listed = h.getEntries().size();
  return {std::max<std::uint64_t>(h.getTotal(), h.getOmitted() + listed + h.getNewer()), h.getOmitted(), h.getNewer()};
}

void print_history(proto::History::Reader h) {
  const auto entries = h.getEntries();
  const PageCounts n = counts_of(h);
  std::uint64_t undone = 0;
  if (entries.size() != 0) {
    struct Row {
      std::string number, tools, mesh, first, end, vertices, size;
      bool undone;
    };
    std::vector<Row> rows;
    Row head{"stroke", "tools", "mesh", "start tick", "end tick", "vertices", "size", false};
    std::size_t w[7] = {};
    auto widen = [&](const Row& r) {
      const std::string* cells[] = {&r.number, &r.tools, &r.mesh, &r.first, &r.end, &r.vertices, &r.size};
      for (int i = 0; i < 7; ++i) w[i] = std::max(w[i], cells[i]->size());
    };
    widen(head);
    for (const auto e : entries) {
      rows.push_back({std::to_string(e.getNumber()), tools_text(e.getTools()),
                      fmt::format("{} ({})", e.getMeshName().cStr(), e.getMesh()), std::to_string(e.getFirstTick()),
                      std::to_string(e.getEndTick()), std::to_string(e.getVertices()), bytes_text(e.getBytes()),
                      e.getUndone()});
      widen(rows.back());
      undone += e.getUndone();
    }
    auto print_row = [&](const Row& r, const char* mark) {
      std::string line = fmt::format("{:>{}}  {:<{}}  {:<{}}  {:>{}}  {:>{}}  {:>{}}  {:>{}}", r.number, w[0], r.tools,
                                     w[1], r.mesh, w[2], r.first, w[3], r.end, w[4], r.vertices, w[5], r.size, w[6]);
      if (*mark) line += std::string("  ") + mark;
      fmt::print("{}\n", line);
    };
    print_row(head, "");
    for (const Row& r : rows) print_row(r, r.undone ? "undone" : "");
  }
  std::string line = fmt::format("{}", strokes(n.total));
  if (undone != 0) line += fmt::format(" ({} undone: redo brings {} back)", undone, undone == 1 ? "it" : "them");
  if (n.older != 0) line += fmt::format(", the {} oldest not listed", n.older);
  if (n.newer != 0) line += fmt::format(", the {} newest not listed", n.newer);
  line += fmt::format("; undo data {} of a {} budget", bytes_text(h.getUsedBytes()), bytes_text(h.getBudgetBytes()));
  if (h.getDropped() != 0) line += fmt::format("; {} fell off the budget", strokes(h.getDropped()));
  fmt::print("{}\n", line);
}

nlohmann::json history_json(proto::History::Reader h) {
  auto list = nlohmann::json::array();
  for (const auto e : h.getEntries()) {
    auto tools = nlohmann::json::array();
    for (const auto t : e.getTools()) tools.push_back(t);
    list.push_back({{"number", e.getNumber()}, {"mesh", e.getMesh()}, {"mesh_name", e.getMeshName().cStr()},
                    {"tools", tools}, {"first_tick", e.getFirstTick()}, {"end_tick", e.getEndTick()},
                    {"vertices", e.getVertices()}, {"bytes", e.getBytes()}, {"undone", e.getUndone()}});
  }
  const PageCounts n = counts_of(h);
  return {{"strokes", list},
          {"budget_bytes", h.getBudgetBytes()},
          {"used_bytes", h.getUsedBytes()},
          {"dropped", h.getDropped()},
          {"omitted", n.older},
          {"total", n.total},
          {"newer", n.newer}};
}

template <class Reply>
void report_history_move(const HistoryMoveArgs& args, const char* what, Reply reply) {
  const auto r = reply.getResult();
  if (args.daemon.json)
    std::cout << nlohmann::json{{"command", what},       {"ok", r.getOk()},        {"error", r.getError().cStr()},
                                {"asked", args.count},   {"done", reply.getDone()}, {"tick", reply.getTick()}}
                     .dump()
              << "\n";
  if (!r.getOk()) {
    if (args.daemon.json) throw CommandFailed{kExitCommandFailed};
    fail(kExitCommandFailed, std::string(what) + ": " + r.getError().cStr());
  }
  if (args.daemon.json) return;
  const char* verb = std::string_view(what) == "undo" ? "undid" : "redid";
  if (reply.getDone() < args.count)
    fmt::print("{} {} of {} at tick {} (no more to {})\n", verb, reply.getDone(), strokes(args.count), reply.getTick(),
               what);
  else
    fmt::print("{} {} at tick {}\n", verb, strokes(reply.getDone()), reply.getTick());
}

}  // namespace

void move_history(const HistoryMoveArgs& args, HistoryMove what) {
  const char* name = what == HistoryMove::undo ? "undo" : "redo";
  if (args.count < 1 || args.count > kMaxHistoryMoveCount)
    fail(kExitUsage, fmt::format("{}: N must be 1 to {} (got {})", name, kMaxHistoryMoveCount, args.count));
  with_daemon(args.daemon, [&](client::Connection& c, kj::WaitScope& ws) {
    require_minor(c, kHistoryMinor, name);
    if (what == HistoryMove::undo) {
      auto req = c.session().undoRequest();
      req.setCount(args.count);
      report_history_move(args, name, req.send().wait(ws));
    } else {
      auto req = c.session().redoRequest();
      req.setCount(args.count);
      report_history_move(args, name, req.send().wait(ws));
    }
  });
}

void history(const HistoryArgs& args) {
  with_daemon(args.daemon, [&](client::Connection& c, kj::WaitScope& ws) {
    require_minor(c, kHistoryMinor, "history");
    // An older daemon answers the newest 16384 whatever is asked: a page it cannot give is refused.
    if (args.from != 0) require_minor(c, kPagedHistoryMinor, "history --from");
    auto req = c.session().historyRequest();
    req.setFrom(args.from);
    req.setLimit(args.limit);
    auto reply = req.send().wait(ws);
    capnp::MallocMessageBuilder trimmed;
    proto::History::Reader h = reply.getHistory();
    if (h.getEntries().size() > args.limit) {
      // An older daemon's whole answer: its newest `limit`.
      auto out = trimmed.initRoot<proto::History>();
      const unsigned skip = h.getEntries().size() - args.limit;
      auto list = out.initEntries(args.limit);
      for (unsigned i = 0; i < args.limit; ++i) list.setWithCaveats(i, h.getEntries()[skip + i]);
      out.setBudgetBytes(h.getBudgetBytes());
      out.setUsedBytes(h.getUsedBytes());
      out.setDropped(h.getDropped());
      out.setOmitted(h.getOmitted() + skip);
      out.setTotal(h.getOmitted() + h.getEntries().size());
      h = out.asReader();
    }
    if (args.daemon.json) std::cout << history_json(h).dump(2) << "\n";
    else print_history(h);
  });
}

}  // namespace sculpt::ctl
