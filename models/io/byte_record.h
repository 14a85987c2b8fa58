// Values written to and read back from a string of bytes, in the writer's own layout: how
// the ranks of one MPI run (runtime/ranks.h) send each other the results of a batch's items.
// Both ends are the same ssc binary, so plain values go as their bytes; a string or vector is
// its size, then its elements. Reading past the end throws std::runtime_error.
#pragma once
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace ssc {

class ByteWriter {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>, "put: a plain value");
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void put_string(const std::string& s) {
    put<long long>((long long)s.size());
    bytes_ += s;
  }
  template <class T>
  void put_vector(const std::vector<T>& v) {
    put<long long>((long long)v.size());
    for (const T& x : v) put(x);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(const std::string& bytes) : bytes_(bytes) {}
  template <class T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>, "get: a plain value");
    need(sizeof(T));
    T v;
    std::memcpy(&v, bytes_.data() + at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  std::string get_string() {
    const size_t n = size();
    need(n);
    std::string s = bytes_.substr(at_, n);
    at_ += n;
    return s;
  }
  template <class T>
  std::vector<T> get_vector() {
    const size_t n = size();
    std::vector<T> v;
    v.reserve(n);
    for (size_t i = 0; i < n; ++i) v.push_back(get<T>());
    return v;
  }
  bool at_end() const { return at_ == bytes_.size(); }

 private:
  size_t size() {
    const long long n = get<long long>();
    if (n < 0 || size_t(n) > bytes_.size() - at_) throw std::runtime_error("a byte record's length is out of range");
    return size_t(n);
  }
  void need(size_t n) const {
    if (n > bytes_.size() - at_) throw std::runtime_error("a byte record ends early");
  }
  const std::string& bytes_;
  size_t at_ = 0;
};

}  // namespace ssc
