// How many tools a world can be driven by: one cap for every room (the
// scene reader, the input mapper, the tool driver, the published state, the
// feedback board), so none can hold a tool another refuses.
#pragma once

#include <cstddef>

namespace sculpt::sim {

inline constexpr std::size_t kMaxTools = 8;  // tool slots

}  // namespace sculpt::sim
