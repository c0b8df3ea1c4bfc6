// Replace a file so that readers (and a crash at any moment) see either the
// old content or the complete new one, never a torn mix.
#pragma once

#include <filesystem>
#include <string_view>

#include "files/regular_file.hpp"  // FileError

namespace sculpt::files {

// Temp file in the same directory (rename is only atomic within one file
// system), write, fsync, rename over `file`, fsync the directory so the
// rename itself survives a power cut. Throws FileError; on failure the
// temp file is removed and `file` is untouched.
void write_file_atomically(const std::filesystem::path& file, std::string_view bytes);

}  // namespace sculpt::files
