// The one place GLES 3 and EGL headers come in, plus small RAII handles for
// GL objects (a name is released with its owner; moves transfer it).
#pragma once

#include <GLES3/gl32.h>

#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace sculpt::view::gl {

// Throws GlError naming `what` when glGetError reports something.
void check(std::string_view what);

struct GlError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A GL object name and the function that deletes it.
template <void (*Delete)(GLuint)>
class Handle {
 public:
  Handle() = default;
  explicit Handle(GLuint name) : name_(name) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& other) noexcept : name_(std::exchange(other.name_, 0)) {}
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      reset();
      name_ = std::exchange(other.name_, 0);
    }
    return *this;
  }
  ~Handle() { reset(); }
  void reset() {
    if (name_ != 0) Delete(name_);
    name_ = 0;
  }
  GLuint get() const { return name_; }
  explicit operator bool() const { return name_ != 0; }

 private:
  GLuint name_ = 0;
};

void delete_buffer(GLuint name);
void delete_vertex_array(GLuint name);
void delete_program(GLuint name);
void delete_framebuffer(GLuint name);
void delete_renderbuffer(GLuint name);

using Buffer = Handle<delete_buffer>;
using VertexArray = Handle<delete_vertex_array>;
using Program = Handle<delete_program>;
using Framebuffer = Handle<delete_framebuffer>;
using Renderbuffer = Handle<delete_renderbuffer>;

Buffer make_buffer();
VertexArray make_vertex_array();

// Compiles and links; throws GlError with the compiler's log and `name`.
Program make_program(std::string_view name, const char* vertex_src, const char* fragment_src);

}  // namespace sculpt::view::gl
