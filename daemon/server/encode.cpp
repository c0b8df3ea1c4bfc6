#include "server/encode.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string_view>

namespace sculpt::server {
namespace {

void set_vec(proto::Vec3::Builder v, const std::array<float, 3>& a) {
  v.setX(a[0]);
  v.setY(a[1]);
  v.setZ(a[2]);
}

void set_quantiles(proto::Quantiles::Builder q, const simloop::Percentiles& p) {
  q.setP50(static_cast<float>(p.p50));
  q.setP99(static_cast<float>(p.p99));
  q.setMax(static_cast<float>(p.max));
}

simloop::Percentiles percentiles(proto::Quantiles::Reader q) { return {q.getP50(), q.getP99(), q.getMax()}; }

}  // namespace

void set_bounds(proto::Aabb::Builder out, const std::array<float, 6>& b) {
  set_vec(out.initMin(), {b[0], b[1], b[2]});
  set_vec(out.initMax(), {b[3], b[4], b[5]});
}

void fill_keyframe(proto::Keyframe::Builder out, const SceneInfo& scene, const PublishedReader& reader) {
  const PublishedHeader& h = reader.header();
  out.setSequence(h.tick);
  out.setSimTimeNs(static_cast<std::uint64_t>(std::llround(static_cast<double>(h.tick) * 1e9 / scene.rate_hz)));
  out.setScene(scene.scene);
  out.setRateHz(static_cast<float>(scene.rate_hz));
  const std::size_t n = std::min(scene.meshes.size(), reader.body_count());
  auto meshes = out.initMeshes(static_cast<unsigned>(n));
  std::array<float, 6> all{};
  for (std::size_t i = 0; i < n; ++i) {
    const MeshInfo& info = scene.meshes[i];
    auto m = meshes[static_cast<unsigned>(i)];
    m.setId(static_cast<std::uint32_t>(i));
    m.setName(info.name);
    auto tris = m.initTriangles(static_cast<unsigned>(info.triangles.size()));
    for (std::size_t k = 0; k < info.triangles.size(); ++k) tris.set(static_cast<unsigned>(k), info.triangles[k]);
    const auto pos = reader.positions(i);
    auto rest = m.initRestPositions(info.rest.size() * 4);
    if (!info.rest.empty()) std::memcpy(rest.begin(), info.rest.data(), info.rest.size() * 4);
    auto cur = m.initPositions(pos.size() * 4);
    if (!pos.empty()) std::memcpy(cur.begin(), pos.data(), pos.size() * 4);
    auto mat = m.initMaterial();
    mat.setName(info.material);
    mat.setModel(info.linear_model ? proto::ForceModel::LINEAR : proto::ForceModel::SPRING);
    mat.setMass(info.mass);
    mat.setStiffness(info.stiffness);
    mat.setDamping(info.damping);
    mat.setAnchor(info.anchor);
    mat.setPlastic(info.plastic);
    mat.setYieldStrain(info.yield_strain);
    mat.setGravity(info.gravity);
    const auto& b = reader.bounds(i);
    set_bounds(m.initBounds(), b);
    m.setSleeping(h.awake_vertices == 0);
    for (int a = 0; a < 3; ++a) {
      all[a] = i == 0 ? b[a] : std::min(all[a], b[a]);
      all[3 + a] = i == 0 ? b[3 + a] : std::max(all[3 + a], b[3 + a]);
    }
  }
  set_bounds(out.initSceneBounds(), all);
  fill_tools(out.initTools(static_cast<unsigned>(std::min<std::size_t>(h.tool_count, scene.tools.size()))), scene, h);
}

void fill_tools(capnp::List<proto::Tool>::Builder out, const SceneInfo& scene, const PublishedHeader& h) {
  for (unsigned t = 0; t < out.size(); ++t) {
    const PublishedTool& p = h.tools[t];
    const ToolInfo& info = scene.tools[t];
    auto o = out[t];
    o.setId(t);
    const bool capsule = p.shape == 1;
    o.setShape(capsule ? proto::ToolShape::CAPSULE : proto::ToolShape::SPHERE);
    o.setRadius(p.radius);
    const auto& ax = p.half_axis;
    const float len = std::sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    o.setHalfLength(capsule ? len : 0.0f);
    set_vec(o.initPosition(), p.position);
    // The rotation that takes +x onto the capsule's axis.
    auto q = o.initOrientation();
    if (capsule && len > 0) {
      const float vx = ax[0] / len, vy = ax[1] / len, vz = ax[2] / len;
      float w = 1 + vx, x = 0, y = -vz, z = vy;
      if (w < 1e-6f) w = 0, x = 0, y = 0, z = 1;  // opposite: half a turn about z
      const float norm = std::sqrt(w * w + x * x + y * y + z * z);
      q.setW(w / norm);
      q.setX(x / norm);
      q.setY(y / norm);
      q.setZ(z / norm);
    } else {
      q.setW(1);
    }
    set_vec(o.initVelocity(), p.velocity);
    o.setGrabbing(p.grab && p.active);
    set_vec(o.initContactForce(), p.force);
    o.setContacts(p.contacts);
    o.setDeviceSlot(info.device_slot);
  }
}

namespace {

// Stats minor 2 (3's workNvcsw, 4's workNvcswNoFault): why ticks overran, exactly as the stats reading (simloop::reading) has it.
void fill_overruns(proto::Stats::Builder out, const simloop::StatsReading& s) {
  using simloop::OverrunCause;
  auto c = out.initOverrunCauses();
  c.setLateWake(s.overrun_causes[static_cast<std::size_t>(OverrunCause::late_wake)]);
  c.setLongStep(s.overrun_causes[static_cast<std::size_t>(OverrunCause::long_step)]);
  c.setLongStepOffCpu(s.long_steps_off_cpu);
  auto recent = out.initRecentOverruns(static_cast<unsigned>(s.recent_overruns.size()));
  for (unsigned i = 0; i < recent.size(); ++i) {
    const simloop::OverrunRecord& r = s.recent_overruns[i];
    auto o = recent[i];
    o.setTick(r.tick);
    o.setCause(r.cause == OverrunCause::long_step ? proto::OverrunCause::LONG_STEP : proto::OverrunCause::LATE_WAKE);
    o.setOffCpu(r.off_cpu);
    o.setCpu(r.cpu);
    o.setLateNs(r.late_ns);
    auto st = o.initStageNs(static_cast<unsigned>(r.stage_ns.size()));
    for (unsigned k = 0; k < st.size(); ++k) st.set(k, r.stage_ns[k]);
    o.setWorkCpuNs(r.counters.work_cpu_ns);
    o.setMinflt(r.counters.minflt);
    o.setMajflt(r.counters.majflt);
    o.setNivcsw(r.counters.nivcsw);
    o.setWorkNvcsw(r.counters.work_nvcsw);
    o.setWorkNvcswNoFault(r.counters.work_nvcsw_no_fault);
  }
  auto t = out.initSimThread();
  t.setMinflt(s.sim_thread.minflt);
  t.setMajflt(s.sim_thread.majflt);
  t.setNivcsw(s.sim_thread.nivcsw);
  t.setWorkNvcsw(s.sim_thread.work_nvcsw);
  t.setWorkNvcswNoFault(s.sim_thread.work_nvcsw_no_fault);
}

void read_overruns(proto::Stats::Reader in, simloop::StatsReading& s) {
  using simloop::OverrunCause;
  const auto c = in.getOverrunCauses();
  s.overrun_causes[static_cast<std::size_t>(OverrunCause::late_wake)] = c.getLateWake();
  s.overrun_causes[static_cast<std::size_t>(OverrunCause::long_step)] = c.getLongStep();
  s.long_steps_off_cpu = c.getLongStepOffCpu();
  for (const auto o : in.getRecentOverruns()) {
    simloop::OverrunRecord r;
    r.tick = o.getTick();
    r.cause = o.getCause() == proto::OverrunCause::LONG_STEP ? OverrunCause::long_step : OverrunCause::late_wake;
    r.off_cpu = o.getOffCpu();
    r.cpu = o.getCpu();
    r.late_ns = o.getLateNs();
    const auto st = o.getStageNs();
    for (unsigned k = 0; k < st.size() && k < r.stage_ns.size(); ++k) r.stage_ns[k] = st[k];
    r.counters.work_cpu_ns = o.getWorkCpuNs();
    r.counters.minflt = o.getMinflt();
    r.counters.majflt = o.getMajflt();
    r.counters.nivcsw = o.getNivcsw();
    r.counters.work_nvcsw = o.getWorkNvcsw();
    r.counters.work_nvcsw_no_fault = o.getWorkNvcswNoFault();
    s.recent_overruns.push_back(r);
  }
  const auto t = in.getSimThread();
  s.sim_thread.minflt = t.getMinflt();
  s.sim_thread.majflt = t.getMajflt();
  s.sim_thread.nivcsw = t.getNivcsw();
  s.sim_thread.work_nvcsw = t.getWorkNvcsw();
  s.sim_thread.work_nvcsw_no_fault = t.getWorkNvcswNoFault();
}

}  // namespace

void fill_stats(proto::Stats::Builder out, const DaemonStatus& d) {
  const simloop::StatsReading& s = d.stats;
  out.setRateHz(static_cast<float>(s.rate_hz));
  out.setTicks(s.ticks);
  out.setOverruns(s.overruns);
  set_quantiles(out.initJitterUs(), s.jitter_us);
  auto stages = out.initStageUs(static_cast<unsigned>(s.stage_us.size()));
  for (unsigned i = 0; i < stages.size(); ++i) {
    stages[i].setStage(simloop::stage_name(static_cast<simloop::Stage>(i)));
    set_quantiles(stages[i].initUs(), s.stage_us[i]);
  }
  out.setVerticesTotal(s.vertices_total);
  out.setVerticesAwake(s.vertices_awake);
  out.setViewers(static_cast<std::uint32_t>(s.viewers));
  out.setDevices(static_cast<std::uint32_t>(s.devices));
  out.setFfUploads(s.ff_uploads);
  out.setBytesSent(s.bytes_sent);
  out.setBlowups(s.blowups);
  out.setPaused(d.paused);
  out.setUptimeS(d.uptime_s);
  out.setScene(d.scene);
  out.setSimTimeNs(d.sim_time_ns);
  auto h = out.initJitterHistogram(static_cast<unsigned>(d.jitter.size()));
  for (unsigned i = 0; i < h.size(); ++i) {
    h[i].setLowerNs(d.jitter[i].lower_ns);
    h[i].setUpperNs(d.jitter[i].upper_ns);
    h[i].setCount(d.jitter[i].count);
  }
  fill_overruns(out, s);
}

void fill_devices(capnp::List<proto::Device>::Builder out, std::span<const DeviceEntry> devices) {
  for (unsigned i = 0; i < out.size() && i < devices.size(); ++i) {
    const DeviceEntry& d = devices[i];
    auto o = out[i];
    o.setSlot(d.slot);
    o.setName(d.name);
    o.setNode(d.node);
    o.setVendor(d.vendor);
    o.setProduct(d.product);
    o.setKind(d.kind);
    o.setConnected(d.connected);
    o.setFf(d.ff == 2 ? proto::FfSupport::CONSTANT : d.ff == 1 ? proto::FfSupport::RUMBLE : proto::FfSupport::NONE);
    auto tools = o.initTools(static_cast<unsigned>(d.tools.size()));
    for (unsigned t = 0; t < tools.size(); ++t) tools.set(t, d.tools[t]);
    o.setFfUploads(d.ff_uploads);
    o.setBus(d.bus);
    o.setGain(static_cast<float>(d.gain));
    o.setLimit(static_cast<float>(d.limit));
  }
}

void fill_history(proto::History::Builder out, const History& history, std::size_t max_entries) {
  // A control that answered more than asked: the newest of its page.
  const std::size_t n = std::min(history.entries.size(), max_entries);
  const std::size_t first = history.entries.size() - n;
  auto list = out.initEntries(static_cast<unsigned>(n));
  for (unsigned i = 0; i < n; ++i) {
    const HistoryEntry& e = history.entries[first + i];
    auto o = list[i];
    o.setNumber(e.number);
    o.setMesh(e.mesh);
    o.setMeshName(e.mesh_name);
    auto tools = o.initTools(static_cast<unsigned>(e.tools.size()));
    for (unsigned t = 0; t < tools.size(); ++t) tools.set(t, e.tools[t]);
    o.setFirstTick(e.first_tick);
    o.setEndTick(e.end_tick);
    o.setVertices(e.vertices);
    o.setBytes(e.bytes);
    o.setUndone(e.undone);
  }
  out.setBudgetBytes(history.budget_bytes);
  out.setUsedBytes(history.used_bytes);
  out.setDropped(history.dropped);
  out.setOmitted(history.older + first);
  out.setTotal(std::max<std::uint64_t>(history.total, history.older + history.entries.size() + history.newer));
  out.setNewer(history.newer);
}

simloop::StatsReading stats_from(proto::Stats::Reader in) {
  simloop::StatsReading s;
  s.rate_hz = in.getRateHz();
  s.ticks = in.getTicks();
  s.overruns = in.getOverruns();
  s.jitter_us = percentiles(in.getJitterUs());
  for (const auto st : in.getStageUs())
    for (int i = 0; i < static_cast<int>(simloop::Stage::count); ++i)
      if (std::string_view(st.getStage().cStr()) == simloop::stage_name(static_cast<simloop::Stage>(i)))
        s.stage_us[static_cast<std::size_t>(i)] = percentiles(st.getUs());
  s.vertices_total = in.getVerticesTotal();
  s.vertices_awake = in.getVerticesAwake();
  s.viewers = in.getViewers();
  s.devices = in.getDevices();
  s.ff_uploads = in.getFfUploads();
  s.bytes_sent = in.getBytesSent();
  s.blowups = in.getBlowups();
  read_overruns(in, s);
  return s;
}

}  // namespace sculpt::server
