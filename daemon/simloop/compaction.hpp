// Whether the kernel may move pages that --realtime's mlockall locked.
// Compaction migrates movable pages to assemble huge pages, and unless
// vm.compact_unevictable_allowed is 0 it moves locked ones too: a thread that
// touches a page being moved waits inside the page fault until it lands, a wait
// in the middle of a tick (stats: work_nvcsw, not work_nvcsw_no_fault). Seen
// here: forcing compaction during 300 ticks of the sim thread's unit test gave a
// wait mid-tick in 1 run of 30 to 4 of 30; without compaction, none in 70.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace sculpt::simloop {

// A warning for --realtime when locked pages may move (the sysctl reads 1);
// nothing for 0, or when it cannot be read (a kernel without compaction).
std::optional<std::string> compaction_warning(std::string_view compact_unevictable_allowed);

// This machine's /proc/sys/vm/compact_unevictable_allowed, "" when unreadable.
std::string current_compact_unevictable_allowed();

}  // namespace sculpt::simloop
