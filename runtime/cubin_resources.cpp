// Registers and static shared memory from a CUBIN's section headers (see cubin_resources.h).
#include "runtime/cubin_resources.h"

#include <cstdint>
#include <cstring>

namespace ssc {
namespace {

constexpr std::uint64_t kReservedShared = 1024;

template <class T>
bool read_at(const std::string& image, std::uint64_t at, T* value) {
  if (at > image.size() || image.size() - at < sizeof(T)) return false;
  std::memcpy(value, image.data() + at, sizeof(T));
  return true;
}

}  // namespace

CubinResources cubin_resources(const std::string& image, const std::string& kernel) {
  CubinResources r;
  // ELF64, little-endian (e_ident: magic, class 2, data 1).
  if (image.size() < 64 || std::memcmp(image.data(), "\x7f" "ELF", 4) != 0 || image[4] != 2 || image[5] != 1) return r;
  std::uint64_t shoff = 0;
  std::uint16_t shentsize = 0, shnum = 0, shstrndx = 0;
  if (!read_at(image, 0x28, &shoff) || !read_at(image, 0x3A, &shentsize) || !read_at(image, 0x3C, &shnum) ||
      !read_at(image, 0x3E, &shstrndx) || shentsize < 64 || shstrndx >= shnum)
    return r;
  auto header = [&](std::uint16_t i) { return shoff + std::uint64_t(i) * shentsize; };
  std::uint64_t names_at = 0, names_size = 0;
  if (!read_at(image, header(shstrndx) + 24, &names_at) || !read_at(image, header(shstrndx) + 32, &names_size) ||
      names_at > image.size() || image.size() - names_at < names_size)
    return r;
  const std::string text = ".text." + kernel, shared = ".nv.shared." + kernel;
  std::uint32_t symbol = 0;
  std::uint64_t info_at = 0, info_size = 0;
  for (std::uint16_t i = 0; i < shnum; ++i) {
    std::uint32_t name = 0, link_info = 0;
    std::uint64_t at = 0, size = 0;
    if (!read_at(image, header(i), &name) || !read_at(image, header(i) + 24, &at) ||
        !read_at(image, header(i) + 32, &size) || !read_at(image, header(i) + 44, &link_info) || name >= names_size)
      return CubinResources{};
    const char* s = image.data() + names_at + name;
    const std::string section(s, strnlen(s, size_t(names_size - name)));
    if (section == text) {
      r.found = true;
      symbol = link_info;  // the kernel's symbol
    } else if (section == shared) {  // with the 1 KB that sm_80 and later reserve, which ptxas does not count
      r.shared_bytes = int(size >= kReservedShared ? size - kReservedShared : size);
    } else if (section == ".nv.info") {
      info_at = at, info_size = size;
    }
  }
  // .nv.info: attributes of 4-byte headers (format, attribute, 16-bit size where the format
  // is 4); EIATTR_REGCOUNT (0x2f) carries the symbol and its register count.
  bool registers = false;
  for (std::uint64_t at = info_at; r.found && at + 4 <= info_at + info_size && at + 4 <= image.size();) {
    const auto format = std::uint8_t(image[at]), attribute = std::uint8_t(image[at + 1]);
    std::uint16_t size = 0;
    if (format == 4 && !read_at(image, at + 2, &size)) break;
    std::uint32_t sym = 0, value = 0;
    if (format == 4 && attribute == 0x2f && size == 8 && read_at(image, at + 4, &sym) && read_at(image, at + 8, &value) &&
        sym == symbol)
      r.registers = int(value), registers = true;
    at += 4 + (format == 4 ? size : 0);
  }
  if (!registers) return CubinResources{};
  return r;
}

}  // namespace ssc
