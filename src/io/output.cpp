#include "dbbkit/io/output.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <random>
#include <set>
#include <system_error>

#include "dbbkit/error.hpp"

namespace dbbkit::io {

namespace fs = std::filesystem;

namespace internal {
namespace {

// The registry the signal handlers read: fixed storage, no allocation, so that the
// handler only reads memory and calls unlink/rmdir (both async-signal-safe).
constexpr int kSlots = 128;
constexpr size_t kPathBytes = 4096;
enum SlotState : int { kFree = 0, kFilling = 1, kFile = 2, kDirectory = 3 };
std::array<std::atomic<int>, kSlots> g_state{};
std::array<std::array<char, kPathBytes>, kSlots> g_path{};

// Blocks the cleanup signals for the lifetime of the guard (so that a temporary is
// never created without being registered, or registered half-written).
class SignalBlock {
 public:
  SignalBlock() {
    sigset_t set;
    sigemptyset(&set);
    for (int s : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaddset(&set, s);
    pthread_sigmask(SIG_BLOCK, &set, &old_);
  }
  ~SignalBlock() { pthread_sigmask(SIG_SETMASK, &old_, nullptr); }

 private:
  sigset_t old_;
};

void remove_registered() {
  for (int pass : {kFile, kDirectory}) {
    for (int i = kSlots - 1; i >= 0; --i) {
      if (g_state[i].load(std::memory_order_acquire) != pass) continue;
      if (pass == kFile) {
        ::unlink(g_path[i].data());
      } else {
        ::rmdir(g_path[i].data());
      }
    }
  }
}

extern "C" void cleanup_and_reraise(int sig) {
  remove_registered();
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

}  // namespace

int register_temporary(const std::string& path, bool directory) {
  if (path.size() + 1 > kPathBytes) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = kFree;
    if (g_state[i].compare_exchange_strong(expected, kFilling, std::memory_order_acq_rel)) {
      std::memcpy(g_path[i].data(), path.c_str(), path.size() + 1);
      g_state[i].store(directory ? kDirectory : kFile, std::memory_order_release);
      return i;
    }
  }
  return -1;  // more temporaries at once than slots: this one is not removed on a signal
}

void unregister_temporary(int slot) {
  if (slot >= 0 && slot < kSlots) g_state[slot].store(kFree, std::memory_order_release);
}

}  // namespace internal

void install_cleanup_handlers() {
  struct sigaction sa {};
  sa.sa_handler = internal::cleanup_and_reraise;
  sigemptyset(&sa.sa_mask);
  for (int s : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaddset(&sa.sa_mask, s);
  sa.sa_flags = SA_RESETHAND;
  for (int s : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) ::sigaction(s, &sa, nullptr);
}

void finish_stdout() {
  std::cout.flush();
  const bool bad = !std::cout || std::fflush(stdout) != 0 || std::ferror(stdout);
  if (bad) {
    const int e = errno;
    std::cout.clear();
    std::clearerr(stdout);
    throw InputError("standard output", "",
                     std::string("cannot write the output: ") + std::strerror(e));
  }
}

struct OutputSet::Entry {
  OutputTarget target;
  bool to_stdout = false;
  std::string directory;  // of the target
  std::string base;       // file name of the target
  std::string temporary;  // once staged
  int slot = -1;
  bool staged = false;
  std::string content;  // standard output only
  std::string backup;   // during commit: a hard link to the file the target replaces
  int backup_slot = -1;
};

namespace {

std::string errno_text(int e) { return std::strerror(e); }

// A fresh name beside the target, created exclusively (no existing file or link followed).
std::string unique_link_name(const std::string& directory, const std::string& base) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  const char* digits = "0123456789abcdefghijklmnopqrstuvwxyz";
  std::string s = directory + "/." + base + ".dbbkit-old-";
  for (int i = 0; i < 10; ++i) s += digits[rng() % 36];
  return s;
}

void remove_temporary(int& slot, std::string& path) {
  if (!path.empty()) ::unlink(path.c_str());
  internal::unregister_temporary(slot);
  slot = -1;
  path.clear();
}

}  // namespace

OutputSet::OutputSet(std::vector<OutputTarget> targets, std::vector<std::string> inputs) {
  std::set<std::string> seen;
  bool have_stdout = false;
  std::vector<std::pair<std::string, std::string>> canonical_inputs;
  for (const std::string& in : inputs) {
    if (in.empty() || in == "-") continue;
    std::error_code ec;
    const fs::path c = fs::weakly_canonical(in, ec);
    if (!ec) canonical_inputs.emplace_back(c.string(), in);
  }
  for (OutputTarget& t : targets) {
    auto e = std::make_unique<Entry>();
    const std::string& p = t.path;
    if (p.empty()) throw InputError(t.option, "", "an empty path (use '-' for standard output)");
    if (p == "-") {
      if (have_stdout)
        throw InputError(t.option, "", "standard output is already the target of another option");
      have_stdout = true;
      e->to_stdout = true;
      e->target = std::move(t);
      entries_.push_back(std::move(e));
      continue;
    }
    std::error_code ec;
    const fs::path canonical = fs::weakly_canonical(p, ec);
    if (ec) throw InputError(p, "", "cannot resolve the output path: " + ec.message());
    for (const auto& [c, in] : canonical_inputs) {
      if (c == canonical.string())
        throw InputError(p, t.option, "the output would overwrite the input file " + in);
    }
    if (!seen.insert(canonical.string()).second) {
      throw InputError(p, t.option, "the same file is the target of two outputs of this run");
    }
    struct stat st {};
    if (::stat(p.c_str(), &st) == 0) {
      if (S_ISDIR(st.st_mode)) throw InputError(p, t.option, "is a directory");
      if (!S_ISREG(st.st_mode)) {
        throw InputError(
            p, t.option,
            "exists and is not a regular file (a device, FIFO or socket): write to a regular file, "
            "or '-' for standard output");
      }
    } else if (errno != ENOENT) {
      // A dangling symlink is ENOENT (rename replaces the link); anything else is reported.
      throw InputError(p, t.option, "cannot inspect the output path: " + errno_text(errno));
    }
    const fs::path path(p);
    const std::string dir = path.has_parent_path() ? path.parent_path().string() : ".";
    struct stat ds {};
    if (::stat(dir.c_str(), &ds) != 0 || !S_ISDIR(ds.st_mode)) {
      throw InputError(p, t.option, "the directory " + dir + " does not exist");
    }
    if (path.filename().empty() || path.filename() == "." || path.filename() == "..") {
      throw InputError(p, t.option, "names a directory, not a file");
    }
    e->directory = dir;
    e->base = path.filename().string();
    e->target = std::move(t);
    entries_.push_back(std::move(e));
  }
}

OutputSet::~OutputSet() {
  for (auto& e : entries_) {
    if (!e->temporary.empty()) remove_temporary(e->slot, e->temporary);
    if (!e->backup.empty()) remove_temporary(e->backup_slot, e->backup);
  }
}

void OutputSet::stage(const std::string& option, const std::string& content) {
  Entry* entry = nullptr;
  for (auto& e : entries_) {
    if (e->target.option == option) entry = e.get();
  }
  if (!entry) throw std::logic_error("OutputSet::stage: no target for option " + option);
  Entry& e = *entry;
  if (e.to_stdout) {
    e.content = content;
    e.staged = true;
    return;
  }
  if (!e.temporary.empty()) remove_temporary(e.slot, e.temporary);
  const std::string& p = e.target.path;
  std::string name = e.directory + "/." + e.base + ".dbbkit-XXXXXX";
  int fd = -1;
  {
    internal::SignalBlock block;
    fd = ::mkostemp(name.data(), O_CLOEXEC);
    if (fd < 0)
      throw InputError(p, e.target.option,
                       "cannot create a file in " + e.directory + ": " + errno_text(errno));
    e.temporary = name;
    e.slot = internal::register_temporary(name);
  }
  // The permissions a newly created file gets (0666 less the umask), not mkstemp's 0600.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  const char* data = content.data();
  size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      remove_temporary(e.slot, e.temporary);
      throw InputError(p, e.target.option, "error while writing: " + errno_text(n < 0 ? err : EIO));
    }
    data += n;
    left -= static_cast<size_t>(n);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    remove_temporary(e.slot, e.temporary);
    throw InputError(p, e.target.option, "error while writing: " + errno_text(err));
  }
  e.staged = true;
}

void OutputSet::withhold(const std::string& option) {
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if ((*it)->target.option != option) continue;
    if (!(*it)->temporary.empty()) remove_temporary((*it)->slot, (*it)->temporary);
    entries_.erase(it);
    return;
  }
}

void OutputSet::commit() {
  if (committed_) return;
  for (auto& e : entries_) {
    if (!e->staged)
      throw std::logic_error("OutputSet::commit: " + e->target.option + " was not staged");
  }
  for (auto& e : entries_) {
    if (!e->to_stdout) continue;
    std::cout << e->content;
    finish_stdout();
  }
  // Keep a hard link to every file about to be replaced, so that a failed rename can restore it.
  for (auto& e : entries_) {
    if (e->to_stdout) continue;
    struct stat st {};
    if (::lstat(e->target.path.c_str(), &st) != 0) continue;
    for (int attempt = 0; attempt < 16; ++attempt) {
      internal::SignalBlock block;
      std::string name = unique_link_name(e->directory, e->base);
      if (::link(e->target.path.c_str(), name.c_str()) == 0) {
        e->backup = name;
        e->backup_slot = internal::register_temporary(name);
        break;
      }
      if (errno != EEXIST) break;  // no hard links here: the rename alone, without a restore
    }
  }
  std::vector<Entry*> done;
  for (auto& e : entries_) {
    if (e->to_stdout) continue;
    if (::rename(e->temporary.c_str(), e->target.path.c_str()) != 0) {
      const int err = errno;
      for (Entry* d : done) {
        if (!d->backup.empty()) {
          ::rename(d->backup.c_str(), d->target.path.c_str());
          internal::unregister_temporary(d->backup_slot);
          d->backup.clear();
        } else {
          ::unlink(d->target.path.c_str());
        }
      }
      throw InputError(e->target.path, e->target.option,
                       "cannot move the finished file into place: " + errno_text(err));
    }
    internal::unregister_temporary(e->slot);
    e->slot = -1;
    e->temporary.clear();
    done.push_back(e.get());
  }
  for (auto& e : entries_) {
    if (!e->backup.empty()) remove_temporary(e->backup_slot, e->backup);
  }
  committed_ = true;
}

void write_output(const std::string& path, const std::string& content,
                  const std::vector<std::string>& inputs, const std::string& option) {
  OutputSet set({{option, path.empty() ? "-" : path}}, inputs);
  set.stage(option, content);
  set.commit();
}

}  // namespace dbbkit::io
