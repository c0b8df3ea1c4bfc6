# sculpt.capnp — the one wire protocol of sculptd (daemon ⇄ viewers ⇄ sculptctl).
#
# Versioning: `protocolMajor` changes only on incompatible changes; a client
# with another major is refused at `Sculptd.hello` with a reason. Minor
# versions only add fields (Cap'n Proto keeps old readers working).
# Field-by-field documentation lives in docs/protocol.md.

@0xef27fb8c011909fa;

$import "/capnp/c++.capnp".namespace("sculpt::proto");

const protocolMajor :UInt16 = 1;
const protocolMinor :UInt16 = 0;

struct Vec3 {
  x @0 :Float32;
  y @1 :Float32;
  z @2 :Float32;
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
  mass @2 :Float32;        # kg per vertex
  stiffness @3 :Float32;   # N/m per spring
  damping @4 :Float32;     # N·s/m per spring
  anchor @5 :Float32;      # N/m towards the rest pose
  plastic @6 :Bool;        # clay: the rest shape yields
  yieldStrain @7 :Float32;
}

struct MeshTopology {
  id @0 :UInt32;
  name @1 :Text;
  triangles @2 :List(UInt32);      # 3 indices per triangle
  restPositions @3 :Data;          # float32 x,y,z per vertex, little-endian
  positions @4 :Data;              # float32 x,y,z per vertex, little-endian
  material @5 :Material;
  bounds @6 :Aabb;
}

enum ToolShape {
  sphere @0;
  capsule @1;
}

struct ToolState {
  id @0 :UInt32;
  shape @1 :ToolShape;
  radius @2 :Float32;
  halfLength @3 :Float32;          # capsule only
  position @4 :Vec3;
  orientation @5 :List(Float32);   # quaternion w,x,y,z
  grabbing @6 :Bool;
  contactForce @7 :Vec3;           # newtons, reaction on the tool
  contacts @8 :UInt32;
}

struct Snapshot {
  sequence @0 :UInt64;
  simTimeNs @1 :UInt64;
  meshes @2 :List(MeshTopology);
  tools @3 :List(ToolState);
  sceneBounds @4 :Aabb;
}

struct MeshDelta {
  meshId @0 :UInt32;
  indices @1 :List(UInt32);        # vertices that moved beyond the viewer's tolerance
  positions @2 :Data;              # float32 x,y,z per listed index
}

struct DeltaFrame {
  sequence @0 :UInt64;
  simTimeNs @1 :UInt64;
  meshes @2 :List(MeshDelta);
  tools @3 :List(ToolState);
}

struct Quantiles {
  p50 @0 :Float32;
  p99 @1 :Float32;
  max @2 :Float32;
}

struct Stats {
  rateHz @0 :Float32;
  ticks @1 :UInt64;
  overruns @2 :UInt64;
  jitterUs @3 :Quantiles;
  verticesTotal @4 :UInt64;
  verticesAwake @5 :UInt64;
  viewers @6 :UInt32;
  devices @7 :UInt32;
  ffUploads @8 :UInt64;
  bytesSent @9 :UInt64;
  blowups @10 :UInt64;
}

# Receives the stream; the daemon calls it. `-> stream` gives per-viewer flow
# control, so a slow viewer is coalesced rather than queued.
interface Viewer {
  snapshot @0 (snapshot :Snapshot) -> stream;
  frame @1 (frame :DeltaFrame) -> stream;
}

interface Sculptd {
  hello @0 (major :UInt16, minor :UInt16, client :Text)
      -> (accepted :Bool, reason :Text, major :UInt16, minor :UInt16, server :Text);
  status @1 () -> (stats :Stats);
  subscribe @2 (viewer :Viewer, toleranceMm :Float32, maxFps :Float32) -> (subscription :Subscription);
}

interface Subscription {
  # Dropping the capability unsubscribes.
  setRate @0 (maxFps :Float32);
}
