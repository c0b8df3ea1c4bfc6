// Whether the kernel lets a waking SCHED_FIFO thread in at once. With
// preemption "none" or "voluntary" a woken real-time thread waits until the
// task on its CPU leaves the kernel or reaches a resched point: a scheduler
// trace here (docs/daemon.md, "Why ticks overrun") showed the sim thread woken
// on time and then kept off its CPU 0.5–2.3 ms by a linker's or a kworker's
// system call, the commonest overrun. The daemon cannot change that; it says so.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace sculpt::simloop {

// The preemption model from what the kernel tells: `uname -v` (its build:
// "PREEMPT_RT", "PREEMPT_DYNAMIC", "PREEMPT" or none of them), the current
// mode of a dynamic kernel from /sys/kernel/debug/sched/preempt ("none
// voluntary (full) lazy"; empty when unreadable: it needs root), else the
// boot's `preempt=` on /proc/cmdline, else the build's default mode from its
// config (/boot/config-<release>: CONFIG_PREEMPT_NONE/_VOLUNTARY/=y/_LAZY).
// Returns "rt", "full", "lazy", "voluntary", "none", or "" when a dynamic
// kernel's mode cannot be read.
std::string preemption_model(std::string_view uname_version, std::string_view debugfs_preempt,
                             std::string_view cmdline, std::string_view kernel_config = {});

// A warning for --realtime when the model delays real-time wake-ups
// (none, voluntary, or unknown); nothing for rt, full and lazy.
std::optional<std::string> preemption_warning(std::string_view model);

// This machine's model (reads uname, debugfs if mounted and readable, /proc/cmdline, /boot/config-*).
std::string current_preemption_model();

}  // namespace sculpt::simloop
