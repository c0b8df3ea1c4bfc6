# sculpt.capnp — the one wire protocol of sculptd (daemon ⇄ viewers ⇄ sculptctl).
#
# Transport: Cap'n Proto RPC (two-party, unpacked) over a Unix stream socket.
# The bootstrap capability is `Sculptd`; it only offers `hello`. A client
# whose major version the daemon speaks gets a `Session`, through which
# everything else goes; any other major is refused with a reason and no
# session, so an incompatible client can never misread a stream.
#
# Versioning: `protocolMajor` changes only on incompatible changes. Minor
# versions only add fields and methods (Cap'n Proto keeps old readers working).
# Field-by-field documentation lives in docs/protocol.md.
#
# Units: metres, seconds, newtons, kilograms. Positions travel as `Data`
# holding packed little-endian float32 x,y,z triples (12 bytes per vertex):
# a List(Float32) would cost the same bytes but one bounds-checked accessor
# call per float on the reading side.

@0xef27fb8c011909fa;

$import "/capnp/c++.capnp".namespace("sculpt::proto");

const protocolMajor :UInt16 = 1;
const protocolMinor :UInt16 = 7;   # 1: Stats.jitterHistogram; 2: Stats.overrunCauses, recentOverruns, simThread; 3: workNvcsw; 4: workNvcswNoFault; 5: Session.undo, redo, history, exportSculpt; 6: Device.bus, gain, limit, Session.tuneHaptics; 7: history's from, limit, History.total, newer

struct Vec3 {
  x @0 :Float32;
  y @1 :Float32;
  z @2 :Float32;
}

struct Quat {
  w @0 :Float32 = 1.0;
  x @1 :Float32;
  y @2 :Float32;
  z @3 :Float32;
}

struct Aabb {
  min @0 :Vec3;
  max @1 :Vec3;
}

enum ForceModel {
  spring @0;   # length-based Hooke spring + damper along the spring
  linear @1;   # the original rest-shape model, a_i = k/m Σ((p_j-p_i)-(r_j-r_i))
}

struct Material {
  name @0 :Text;
  model @1 :ForceModel;
  mass @2 :Float32;          # kg per vertex
  stiffness @3 :Float32;     # N/m per spring
  damping @4 :Float32;       # N·s/m per spring (the parallel damper)
  anchor @5 :Float32;        # N/m towards the rest pose
  plastic @6 :Bool;          # clay: the rest shape yields
  yieldStrain @7 :Float32;   # relative strain beyond which clay yields
  gravity @8 :Bool;
}

struct Mesh {
  id @0 :UInt32;                   # stable for the life of the loaded scene
  name @1 :Text;
  triangles @2 :List(UInt32);      # 3 vertex indices per triangle
  restPositions @3 :Data;          # float32 x,y,z per vertex
  positions @4 :Data;              # float32 x,y,z per vertex, the current shape
  material @5 :Material;
  bounds @6 :Aabb;                 # of the current positions
  sleeping @7 :Bool;
}

enum ToolShape {
  sphere @0;
  capsule @1;
}

struct Tool {
  id @0 :UInt32;
  shape @1 :ToolShape;
  radius @2 :Float32;
  halfLength @3 :Float32;          # capsule only: half the distance between its end centres
  position @4 :Vec3;
  orientation @5 :Quat;
  velocity @6 :Vec3;
  grabbing @7 :Bool;
  contactForce @8 :Vec3;           # newtons: the reaction of the mesh on the tool
  contacts @9 :UInt32;             # vertices in contact this tick
  deviceSlot @10 :Int32 = -1;      # which device slot drives it (-1: none)
}

# A viewer's keyframe: the whole state, when it joins and after a scene load
# or reset. The explicit ID is the one this struct had as `Snapshot`.
struct Keyframe @0x826e371020de7da3 {
  sequence @0 :UInt64;             # the sim tick it shows; frames continue from it
  simTimeNs @1 :UInt64;
  meshes @2 :List(Mesh);
  tools @3 :List(Tool);
  sceneBounds @4 :Aabb;
  scene @5 :Text;                  # where the scene came from (a path or "builtin:default")
  rateHz @6 :Float32;
}

struct MeshDelta {
  meshId @0 :UInt32;
  indices @1 :List(UInt32);        # ascending: vertices that moved beyond the viewer's tolerance
  positions @2 :Data;              # float32 x,y,z per listed index, in the same order
  bounds @3 :Aabb;                 # of the current positions (for the viewer's boxes)
}

struct DeltaFrame {
  sequence @0 :UInt64;             # sim tick; strictly increasing per viewer, gaps = coalesced ticks
  simTimeNs @1 :UInt64;
  publishedNs @2 :Int64;           # CLOCK_MONOTONIC when the sim published this tick (latency)
  meshes @3 :List(MeshDelta);      # only meshes with changes; empty in a keep-alive
  tools @4 :List(Tool);            # every tool, every frame (a few dozen bytes each)
  stats @5 :Stats;                 # set at most about once a second (the viewer's overlay)
  hasStats @6 :Bool;
}

struct Quantiles {
  p50 @0 :Float32;
  p99 @1 :Float32;
  max @2 :Float32;
}

struct StageTime {
  stage @0 :Text;                  # input, collision, integration, publish
  us @1 :Quantiles;
}

struct Stats {
  rateHz @0 :Float32;
  ticks @1 :UInt64;
  overruns @2 :UInt64;
  jitterUs @3 :Quantiles;
  stageUs @4 :List(StageTime);
  verticesTotal @5 :UInt64;
  verticesAwake @6 :UInt64;
  viewers @7 :UInt32;
  devices @8 :UInt32;
  ffUploads @9 :UInt64;
  bytesSent @10 :UInt64;
  blowups @11 :UInt64;
  paused @12 :Bool;
  uptimeS @13 :Float64;
  scene @14 :Text;
  simTimeNs @15 :UInt64;
  # (minor 1) The sim loop's wake-up lateness since it started, bucket by
  # bucket (only non-empty buckets): two reads diffed give the jitter of what
  # happened in between (the streaming benchmark compares windows with it).
  jitterHistogram @16 :List(HistogramBucket);
  # (minor 2) Why ticks overran (daemon/simloop/overrun.hpp): counts by cause
  # since the loop started, the last few overruns, and the sim thread's own
  # kernel counters since the loop started.
  overrunCauses @17 :OverrunCauses;
  recentOverruns @18 :List(Overrun);
  simThread @19 :SimThreadCounters;
}

# An overrun's cause is whichever of wake-up lateness and work was larger.
enum OverrunCause {
  lateWake @0;
  longStep @1;
}

struct OverrunCauses {
  lateWake @0 :UInt64;
  longStep @1 :UInt64;
  longStepOffCpu @2 :UInt64;       # of longStep: the thread was off the CPU for most of the work
}

struct Overrun {
  tick @0 :UInt64;
  cause @1 :OverrunCause;
  offCpu @2 :Bool;                 # a long step mostly off the CPU
  cpu @3 :Int32;                   # the CPU it woke on (-1: unknown)
  lateNs @4 :Int64;                # wake − deadline
  stageNs @5 :List(UInt64);        # input, collision, integration, publish (stageUs' order)
  workCpuNs @6 :UInt64;            # the thread's CPU time over the work
  minflt @7 :UInt64;               # page faults over the tick
  majflt @8 :UInt64;
  nivcsw @9 :UInt64;               # involuntary context switches over the tick
  workNvcsw @10 :UInt64;           # (minor 3) voluntary switches over the work: the thread waited
  workNvcswNoFault @11 :UInt64;    # (minor 4) the same, if the work took no page fault (else 0)
}

struct SimThreadCounters {
  minflt @0 :UInt64;
  majflt @1 :UInt64;
  nivcsw @2 :UInt64;
  workNvcsw @3 :UInt64;            # (minor 3) voluntary switches mid-tick (a blocking call, or a page the kernel moved)
  workNvcswNoFault @4 :UInt64;     # (minor 4) those in ticks without a page fault: 0 unless the thread blocked
}

struct HistogramBucket {
  lowerNs @0 :UInt64;              # values in [lowerNs, upperNs)
  upperNs @1 :UInt64;
  count @2 :UInt64;
}

enum FfSupport {
  none @0;
  rumble @1;                       # rumble only: the contact force as rumble, and kicks
  constant @2;                     # constant force (and rumble when the device has it)
}

struct Device {
  slot @0 :UInt32;                 # stays with the device across unplug/plug
  name @1 :Text;
  node @2 :Text;                   # /dev/input/eventN ("" while unplugged)
  vendor @3 :UInt16;
  product @4 :UInt16;
  kind @5 :Text;                   # "gamepad", "joystick"
  connected @6 :Bool;
  ff @7 :FfSupport;
  tools @8 :List(UInt32);          # tool ids it drives
  ffUploads @9 :UInt64;
  # (minor 6) Its transport ("usb", "bluetooth", "virtual", ...; "" unknown:
  # it sets how often its motors may be updated), and its force-feedback
  # tuning, each 0..1 of full: `gain` scales every level, `limit` caps it.
  bus @10 :Text;
  gain @11 :Float32 = 1.0;
  limit @12 :Float32 = 1.0;
}

struct Result {
  ok @0 :Bool;
  error @1 :Text;                  # what went wrong, naming the file/field, when not ok
}

# (minor 5) One stroke: one tool's contact with a mesh from onset to release
# (a grab from press to release).
struct HistoryEntry {
  number @0 :UInt32;               # counting from 1 since the daemon's store was made
  mesh @1 :UInt32;                 # the Mesh.id it changed
  meshName @2 :Text;
  tools @3 :List(UInt32);          # the tool ids that took part
  firstTick @4 :UInt64;            # onset
  endTick @5 :UInt64;              # release
  vertices @6 :UInt64;             # vertices the stroke changed
  bytes @7 :UInt64;                # memory its undo data takes
  undone @8 :Bool;                 # on the redo side: undone, redo brings it back
}

# (minor 5) The daemon's stroke history, bounded by a memory budget (the
# oldest strokes fall off first); (minor 7) one page of it.
struct History {
  entries @0 :List(HistoryEntry);  # oldest first; at most 16384 (the newest, unless a page was asked for)
  budgetBytes @1 :UInt64;
  usedBytes @2 :UInt64;
  dropped @3 :UInt64;              # strokes that fell off the budget so far
  omitted @4 :UInt64;              # older strokes the daemon holds that this list leaves out
  total @5 :UInt64;                # (minor 7) strokes the daemon holds
  newer @6 :UInt64;                # (minor 7) newer strokes it holds that this list leaves out
}

# (minor 5) An export being read: a file the daemon wrote and holds open
# (no path to it on its side). Read it in chunks from offset 0 to `size`;
# dropping the capability closes it. A reader nobody reads for 60 s is closed.
interface ExportReader {
  # At most `count` bytes from `offset`, and at most 4 MiB: fewer only at the
  # end, none at `offset` = size. An offset past the end fails naming it.
  read @0 (offset :UInt64, count :UInt32) -> (data :Data);
}

# Receives the stream; the daemon calls it. `-> stream` gives per-viewer flow
# control: while a viewer has not taken its last frame the daemon does not
# queue more, it coalesces (the next frame carries the latest state).
interface Viewer {
  keyframe @0 (keyframe :Keyframe) -> stream;
  frame @1 (frame :DeltaFrame) -> stream;
}

interface Sculptd {
  hello @0 (major :UInt16, minor :UInt16, client :Text)
      -> (accepted :Bool, reason :Text, major :UInt16, minor :UInt16, server :Text, session :Session);
}

interface Session {
  status @0 () -> (stats :Stats);
  devices @1 () -> (devices :List(Device));
  # The whole current state, once (sculptctl save exports it on the client side,
  # with the user's own permissions, in the format its file name asks for).
  keyframe @2 () -> (keyframe :Keyframe);
  # Starts a stream to `viewer`: a keyframe, then delta frames at most
  # `maxFps` a second carrying vertices that moved more than `toleranceM`
  # (metres) since what this viewer last received. Dropping the returned
  # capability (or disconnecting) ends it.
  subscribe @3 (viewer :Viewer, toleranceM :Float32, maxFps :Float32) -> (subscription :Subscription);
  # A scene file on the daemon's side (an absolute path, or "builtin:default").
  # The current sculpt is kept when loading fails.
  loadScene @4 (path :Text) -> (result :Result);
  reset @5 () -> (result :Result);   # every mesh back to its rest shape as loaded
  pause @6 () -> (result :Result);
  resume @7 () -> (result :Result);
  # (minor 5) Undo / redo the last `count` strokes (1 to 10000). `done`: how
  # many were; `tick`: the sim tick at which it applied. Refused (result.error)
  # when there is nothing to undo/redo, or the stroke was made before a scene
  # load or reset.
  undo @8 (count :UInt32) -> (result :Result, done :UInt32, tick :UInt64);
  redo @9 (count :UInt32) -> (result :Result, done :UInt32, tick :UInt64);
  # (minor 7) One page: the strokes numbered `from` and up (0: the newest),
  # at most `limit` (0, or more than 16384: 16384). A client of minor 5 or 6
  # sends neither and gets the newest 16384, as before. Each call costs the
  # daemon the page it answers, not the whole history.
  history @10 (from :UInt32, limit :UInt32) -> (history :History);
  # (minor 5) The whole sculpt (scene, meshes, current state, history) as one
  # .sculpt file, `size` bytes, read through `reader`. At most 2 exports per
  # connection and 8 in all may be open (being written, or held): past that,
  # result.error says so.
  exportSculpt @11 () -> (result :Result, size :UInt64, reader :ExportReader);
  # (minor 6) The force-feedback gain and hard limit of the device on `slot`
  # (each 0..1 of full), until the daemon restarts or reloads its config
  # (SIGHUP); the slot keeps them across unplug and replug. Only what is set
  # changes; the reply has both as they are now. Refused (result.error) for
  # an unknown slot, a value outside 0..1 (NaN included), or haptics off.
  tuneHaptics @12 (slot :UInt32, setGain :Bool, gain :Float32, setLimit :Bool, limit :Float32)
      -> (result :Result, gain :Float32, limit :Float32);
}

interface Subscription {
  setRate @0 (maxFps :Float32);
  setTolerance @1 (toleranceM :Float32);
}
