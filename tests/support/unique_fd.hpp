// Owns a file descriptor: the production one (daemon/uinput), under the name
// the tests have always used.
#pragma once

#include "uinput/unique_fd.hpp"

namespace sculpt::support {

using uinput::UniqueFd;

}  // namespace sculpt::support
