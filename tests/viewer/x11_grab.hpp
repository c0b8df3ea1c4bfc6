// A screenshot of an X server's root window, taken from outside the viewer
// (Xlib's macros stay in x11_grab.cpp: they clash with GoogleTest's names).
#pragma once

#include <string>

#include "gl/png_io.hpp"

namespace sculpt::viewtest {

// Empty image when the display cannot be opened.
view::Image grab_root(const std::string& display);

// Sends a key press and release (XSendEvent) to the top-level window titled
// `title`; `key` is a keysym name ("s", "w"). False when there is no such window.
bool send_key(const std::string& display, const std::string& title, const std::string& key);

}  // namespace sculpt::viewtest
