#include "x11_grab.hpp"

#include <X11/Xlib.h>
#include <X11/Xutil.h>

namespace sculpt::viewtest {

view::Image grab_root(const std::string& display) {
  Display* d = XOpenDisplay(display.c_str());
  if (d == nullptr) return {};
  const ::Window root = DefaultRootWindow(d);
  XWindowAttributes attr{};
  XGetWindowAttributes(d, root, &attr);
  XImage* xi = XGetImage(d, root, 0, 0, static_cast<unsigned>(attr.width), static_cast<unsigned>(attr.height), AllPlanes,
                         ZPixmap);
  view::Image img{attr.width, attr.height, {}};
  if (xi != nullptr) {
    img.rgba.reserve(static_cast<std::size_t>(attr.width) * static_cast<std::size_t>(attr.height) * 4);
    for (int y = 0; y < attr.height; ++y) {
      for (int x = 0; x < attr.width; ++x) {
        const unsigned long p = XGetPixel(xi, x, y);
        img.rgba.insert(img.rgba.end(), {static_cast<std::uint8_t>((p & xi->red_mask) >> 16),
                                         static_cast<std::uint8_t>((p & xi->green_mask) >> 8),
                                         static_cast<std::uint8_t>(p & xi->blue_mask), 255});
      }
    }
    XDestroyImage(xi);
  } else {
    img = {};
  }
  XCloseDisplay(d);
  return img;
}

namespace {

::Window find_titled(Display* d, ::Window w, const std::string& title) {
  char* name = nullptr;
  if (XFetchName(d, w, &name) != 0 && name != nullptr) {
    const bool match = title == name;
    XFree(name);
    if (match) return w;
  }
  ::Window root = 0, parent = 0, *children = nullptr;
  unsigned n = 0;
  ::Window found = 0;
  if (XQueryTree(d, w, &root, &parent, &children, &n) != 0) {
    for (unsigned i = 0; i < n && found == 0; ++i) found = find_titled(d, children[i], title);
    if (children != nullptr) XFree(children);
  }
  return found;
}

}  // namespace

bool send_key(const std::string& display, const std::string& title, const std::string& key) {
  Display* d = XOpenDisplay(display.c_str());
  if (d == nullptr) return false;
  const ::Window w = find_titled(d, DefaultRootWindow(d), title);
  if (w != 0) {
    XKeyEvent e{};
    e.display = d;
    e.window = w;
    e.root = DefaultRootWindow(d);
    e.same_screen = True;
    e.keycode = XKeysymToKeycode(d, XStringToKeysym(key.c_str()));
    e.time = CurrentTime;
    e.type = KeyPress;
    XSendEvent(d, w, True, KeyPressMask, reinterpret_cast<XEvent*>(&e));
    e.type = KeyRelease;
    XSendEvent(d, w, True, KeyReleaseMask, reinterpret_cast<XEvent*>(&e));
    XSync(d, False);
  }
  XCloseDisplay(d);
  return w != 0;
}

}  // namespace sculpt::viewtest
