// Journal entries as the store's journal records: compact bytes (a frame
// keeps only its events, what ControlMapper::apply reads), and back. The
// tick travels beside the bytes (store::Record::tick).
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "keeper/journal.hpp"

namespace sculpt::daemon {

// Appends the entry's bytes (without its tick) to `out`.
void encode_entry(const JournalEntry& entry, std::vector<std::byte>& out);
// The entry, its tick set to `tick`; nullopt (and `error` says why) for
// bytes that are not a whole entry.
std::optional<JournalEntry> decode_entry(std::span<const std::byte> bytes, std::uint64_t tick, std::string& error);

}  // namespace sculpt::daemon
