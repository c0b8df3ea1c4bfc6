// Test-only switches for the kernels (kernels.hpp): tests and benchmarks use
// them to run every code path on one machine and compare the bits. Production
// code never calls them. Both are process-wide and start off.
#pragma once

namespace sculpt::sim::kernel::testing {

// Never take the hand-written AVX2 paths, packed or gathering (the portable
// clones still run).
void force_portable(bool on);
// Run whole blocks of the fused pass as separate pieces (forces, integrate,
// pack) instead of the one-pass block kernel.
void force_block_pieces(bool on);

// Sets a switch for one scope and turns it off again (its default) at the end,
// whatever happens in between.
template <void (*Set)(bool)>
class ScopedSwitch {
 public:
  explicit ScopedSwitch(bool on) { Set(on); }
  ~ScopedSwitch() { Set(false); }
  ScopedSwitch(const ScopedSwitch&) = delete;
  ScopedSwitch& operator=(const ScopedSwitch&) = delete;
};
using ScopedPortable = ScopedSwitch<force_portable>;
using ScopedBlockPieces = ScopedSwitch<force_block_pieces>;

}  // namespace sculpt::sim::kernel::testing
