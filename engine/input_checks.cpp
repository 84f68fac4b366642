// Checks of input that every loader shares: text that must be UTF-8, names that name output files, and input files
// that must be regular files of a bounded size (engine/input_file.h).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include <crumple/engine/input_file.h>
#include <crumple/engine/scene.h>

namespace crumple {

namespace {

// The length of the well-formed UTF-8 sequence at text[i], or 0 when the byte there starts none.
size_t utf8Sequence(const std::string& text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = byte(i);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;  // no overlong forms
    if (c == 0xED) hi = 0x9F;  // no surrogates
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;  // no overlong forms
    if (c == 0xF4) hi = 0x8F;  // nothing beyond U+10FFFF
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (size_t k = 2; k < n; ++k)
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
  return n;
}

std::string hexByte(unsigned char c) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "\\x%02X", c);
  return buf;
}

}  // namespace

bool isValidUtf8(const std::string& text) {
  for (size_t i = 0; i < text.size();) {
    const size_t n = utf8Sequence(text, i);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string escapeInvalidUtf8(const std::string& text) {
  if (isValidUtf8(text)) return text;
  std::string out;
  for (size_t i = 0; i < text.size();) {
    const size_t n = utf8Sequence(text, i);
    if (n == 0) {
      out += hexByte(static_cast<unsigned char>(text[i]));
      ++i;
    } else {
      out.append(text, i, n);
      i += n;
    }
  }
  return out;
}

std::string quoteText(const std::string& text, size_t limit) {
  // Characters (UTF-8 sequences, or one escaped byte each), escaped.
  std::vector<std::string> chars;
  for (size_t i = 0; i < text.size();) {
    const size_t n = utf8Sequence(text, i);
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (n == 0) {
      chars.push_back(hexByte(c));
      ++i;
      continue;
    }
    if (c == '\n')
      chars.push_back("\\n");
    else if (c == '\t')
      chars.push_back("\\t");
    else if (c == '\r')
      chars.push_back("\\r");
    else if (c < 32 || c == 127)
      chars.push_back(hexByte(c));
    else
      chars.push_back(text.substr(i, n));
    i += n;
  }
  std::string out;
  if (chars.size() <= limit) {
    for (const std::string& c : chars) out += c;
    return out;
  }
  const size_t keep = limit / 2;
  for (size_t i = 0; i < keep; ++i) out += chars[i];
  out += "...(" + std::to_string(chars.size() - 2 * keep) + " characters)...";
  for (size_t i = chars.size() - keep; i < chars.size(); ++i) out += chars[i];
  return out;
}

std::string fileNameProblem(const std::string& name) {
  if (name.empty()) return "must not be empty";
  if (name.size() > kMaxNameBytes) return "longer than " + std::to_string(kMaxNameBytes) + " characters";
  if (!isValidUtf8(name)) return "is not valid UTF-8";
  for (unsigned char c : name)
    if (c < 32 || c == '/' || c == '\\' || c == 127)
      return "must not contain '/', '\\' or control characters (it names output files)";
  if (name == "." || name == "..") return "must not be '.' or '..'";
  return "";
}

std::string byteSize(std::uintmax_t bytes) {
  if (bytes >= (std::uintmax_t(1) << 30) && bytes % (std::uintmax_t(1) << 30) == 0)
    return std::to_string(bytes >> 30) + " GiB";
  if (bytes >= (std::uintmax_t(1) << 20) && bytes % (std::uintmax_t(1) << 20) == 0)
    return std::to_string(bytes >> 20) + " MiB";
  return std::to_string(bytes) + " bytes";
}

namespace {

// Why a file of this type and size is not read ("" when it is).
std::string statProblem(const struct stat& st, std::uintmax_t maxBytes, const char* what) {
  const mode_t type = st.st_mode & S_IFMT;
  if (type == S_IFDIR) return std::string("is a folder, not a ") + what;
  if (type == S_IFIFO) return "is a FIFO (named pipe), not a regular file: refusing to read it";
  if (type == S_IFCHR) return "is a character device, not a regular file: refusing to read it";
  if (type == S_IFBLK) return "is a block device, not a regular file: refusing to read it";
  if (type == S_IFSOCK) return "is a socket, not a regular file: refusing to read it";
  if (type != S_IFREG) return "is not a regular file: refusing to read it";
  if (static_cast<std::uintmax_t>(st.st_size) > maxBytes)
    return "is larger than " + byteSize(maxBytes) + " (" + std::to_string(st.st_size) + " bytes): refusing to read it";
  return "";
}

std::string errnoProblem(int err) {
  if (err == ENOENT || err == ENOTDIR) return "no such file";
  return std::string("cannot be read (") + std::strerror(err) + ")";
}

}  // namespace

std::string inputFileProblem(const std::string& path, std::uintmax_t maxBytes, const char* what) {
  if (path.find('\0') != std::string::npos) return "the path holds a NUL byte";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return errnoProblem(errno);
  return statProblem(st, maxBytes, what);
}

std::string readInputFile(const std::string& path, std::uintmax_t maxBytes, const char* what) {
  // stat first: opening some devices has effects of its own, and opening a FIFO waits for a writer.
  if (const std::string why = inputFileProblem(path, maxBytes, what); !why.empty()) throw InputFileError(why);
  // O_NONBLOCK: a FIFO swapped in since the stat does not block the open; fstat refuses it below.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw InputFileError(errnoProblem(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw InputFileError(errnoProblem(errno));
  if (const std::string why = statProblem(st, maxBytes, what); !why.empty()) throw InputFileError(why);
  std::string text;
  text.reserve(static_cast<size_t>(st.st_size));
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputFileError(errnoProblem(errno));
    }
    if (n == 0) break;
    if (text.size() + static_cast<size_t>(n) > maxBytes)
      throw InputFileError("is larger than " + byteSize(maxBytes) + ": refusing to read it");
    text.append(buf, static_cast<size_t>(n));
  }
  return text;
}

}  // namespace crumple
