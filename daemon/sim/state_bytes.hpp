// A world's state as bytes (World::state / World::restore_state): fixed-size
// values and arrays appended in order, and read back with every size
// checked against the world being restored, so a state from another scene,
// build or precision is refused by name rather than misread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <algorithm>
#include <vector>

#include "sim/aligned_buffer.hpp"

namespace sculpt::sim {

class StateWriter {
 public:
  explicit StateWriter(std::vector<std::byte>& out) : out_(out) {}
  template <class T>
  void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(&v, sizeof v);
  }
  template <class T>
  void array(std::span<const T> a) {
    static_assert(std::is_trivially_copyable_v<T>);
    value(static_cast<std::uint64_t>(a.size()));
    bytes(a.data(), a.size_bytes());
  }
  template <class T>
  void array(const AlignedBuffer<T>& a) { array(a.span()); }
  template <class T>
  void array(const std::vector<T>& a) { array(std::span<const T>(a)); }

 private:
  void bytes(const void* p, std::size_t n) {
    if (n == 0) return;
    const std::size_t at = out_.size();
    out_.resize(at + n);
    std::memcpy(out_.data() + at, p, n);
  }
  std::vector<std::byte>& out_;
};

// Where a state's values are, found by a dry pass (StateReader::note_to):
// by the address of the field or array each is read into, so checks can look
// at the values a state holds before the real pass writes any of them.
class StateView {
 public:
  // Elements of type T read from bytes that need not be aligned.
  template <class T>
  struct Array {
    std::span<const std::byte> bytes;
    std::size_t size() const { return bytes.size() / sizeof(T); }
    T operator[](std::size_t i) const {
      T v;
      std::memcpy(&v, bytes.data() + i * sizeof(T), sizeof(T));
      return v;
    }
    // Element i's bytes (a bool or an enum is checked as bytes, never loaded).
    std::span<const std::byte> element(std::size_t i) const { return bytes.subspan(i * sizeof(T), sizeof(T)); }
  };

  void note(const void* key, std::span<const std::byte> bytes) { at_[key] = bytes; }
  bool has(const void* key) const { return at_.count(key) != 0; }
  // The state's value of `field` (the world's own object names it).
  template <class T>
  T value(const T& field) const {
    T v;
    std::memcpy(&v, bytes_of(&field).data(), sizeof(T));
    return v;
  }
  // The state's bytes of `field`, for one whose bytes are checked first (a bool).
  std::span<const std::byte> bytes_of(const void* key) const {
    const auto it = at_.find(key);
    if (it == at_.end()) throw std::logic_error("state: a field the dry pass did not see");
    return it->second;
  }
  // The state's elements of an array of the world (std::vector, AlignedBuffer).
  template <class C>
  auto array(const C& a) const {
    using T = std::remove_cv_t<std::remove_reference_t<decltype(*a.data())>>;
    return Array<T>{bytes_of(&a)};
  }

 private:
  std::unordered_map<const void*, std::span<const std::byte>> at_;
};

class StateReader {
 public:
  // dry: check every size and the length, write nothing (a first pass, so a
  // bad state is refused before any of it is applied).
  StateReader(std::span<const std::byte> in, bool dry) : in_(in), dry_(dry) {}
  // Dry pass: note where every field's and array's bytes are (StateView).
  void note_to(StateView* view) { view_ = view; }
  // A value the caller checks (read in either pass).
  template <class T>
  void value(T& v, const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(&v, sizeof v, what, /*write=*/true);
  }
  // A field of the world (left alone in a dry pass).
  template <class T>
  void field(T& v, const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (view_ && in_.size() - at_ >= sizeof v) view_->note(&v, in_.subspan(at_, sizeof v));
    bytes(&v, sizeof v, what, !dry_);
  }
  // Into an array that already has the size the state must carry (a world's
  // array: left alone in a dry pass unless `always`).
  template <class T>
  void array(std::span<T> a, const char* what, bool always = false) {
    array_at(nullptr, a, what, always);
  }
  template <class T>
  void array(AlignedBuffer<T>& a, const char* what) { array_at(&a, a.span(), what, false); }
  template <class T>
  void array(std::vector<T>& a, const char* what) { array_at(&a, std::span<T>(a), what, false); }
  bool done() const { return at_ == in_.size(); }
  bool dry() const { return dry_; }
  std::size_t left() const { return in_.size() - at_; }
  // n bytes as they are (a reader's own variable-length fields).
  void raw(void* p, std::size_t n, const char* what) { bytes(p, n, what, true); }
  // The next n bytes, in place.
  std::span<const std::byte> take(std::size_t n, const char* what) {
    if (in_.size() - at_ < n) throw std::invalid_argument(std::string("state: truncated in ") + what);
    at_ += n;
    return in_.subspan(at_ - n, n);
  }

 private:
  template <class T>
  void array_at(const void* key, std::span<T> a, const char* what, bool always) {
    std::uint64_t n = 0;
    value(n, what);
    if (n != a.size())
      throw std::invalid_argument(std::string("state: ") + what + " has " + std::to_string(n) + " entries, the scene " +
                                  std::to_string(a.size()));
    if (view_ && key && in_.size() - at_ >= a.size_bytes()) view_->note(key, in_.subspan(at_, a.size_bytes()));
    bytes(a.data(), a.size_bytes(), what, always || !dry_);
  }
  void bytes(void* p, std::size_t n, const char* what, bool write) {
    if (in_.size() - at_ < n) throw std::invalid_argument(std::string("state: truncated in ") + what);
    if (write && n > 0) std::memcpy(p, in_.data() + at_, n);  // an empty array may have no storage
    at_ += n;
  }
  std::span<const std::byte> in_;
  std::size_t at_ = 0;
  bool dry_;
  StateView* view_ = nullptr;
};

}  // namespace sculpt::sim
