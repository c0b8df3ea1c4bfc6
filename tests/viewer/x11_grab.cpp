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

}  // namespace sculpt::viewtest
