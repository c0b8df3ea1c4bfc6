// Owns a file descriptor: the production one (daemon/files), under the name
// the tests have always used.
#pragma once

#include "files/unique_fd.hpp"

namespace sculpt::support {

using files::UniqueFd;

}  // namespace sculpt::support
