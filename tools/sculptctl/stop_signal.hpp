// SIGINT and SIGTERM as a request to stop, for the commands that run until
// told (record, replay). Installed without SA_RESTART: a signal ends a sleep
// or poll early, so the command notices at once.
#pragma once

namespace sculpt::ctl {

void catch_stop_signals();
bool stop_requested();

}  // namespace sculpt::ctl
