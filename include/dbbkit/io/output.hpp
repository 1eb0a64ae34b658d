#pragma once
// Writing results without losing data.
//
// All the outputs of one run form an OutputSet. Its targets are checked when the
// set is made, before any work is done: a target that names an input, or another
// output of the run, or that exists and is not a regular file (a directory, a
// device, a FIFO, a socket) is refused, as is an empty path or a directory that
// does not exist. stage() writes the content into a new temporary file in the
// target's directory (mkstemp: a fresh name, created exclusively, so no existing
// file or planted symlink is ever written through), checking every write and the
// close. commit() renames the temporaries into place only when every output is
// complete; when one rename fails, the targets already replaced are restored. A set
// destroyed without commit() (an exception, a failed report) removes its
// temporaries, so a failed run leaves no output and touches no existing file.
// Temporaries are also removed on SIGINT, SIGTERM and SIGHUP (see
// install_cleanup_handlers()).
//
// "-" is standard output: written at commit(), and a write error there (a full
// disk, a closed pipe) is an InputError too.

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace dbbkit::io {

struct OutputTarget {
  std::string option;  // e.g. "--out", named in every message
  std::string path;    // "-" for standard output
};

class OutputSet {
 public:
  // Throws InputError naming the option of the first target that cannot be written.
  OutputSet(std::vector<OutputTarget> targets, std::vector<std::string> inputs);
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // Writes the content of the target given by `option` to its temporary (or keeps
  // it for standard output). A target absent from the set is a programming error.
  void stage(const std::string& option, const std::string& content);
  // Leaves the target of `option` as it is (nothing to write, e.g. no design found):
  // commit passes over it.
  void withhold(const std::string& option);
  // Moves every staged output into place; throws InputError when one cannot be.
  void commit();

 private:
  struct Entry;
  std::vector<std::unique_ptr<Entry>> entries_;
  bool committed_ = false;
};

// One output alone: an OutputSet of one target, staged and committed.
void write_output(const std::string& path, const std::string& content,
                  const std::vector<std::string>& inputs = {}, const std::string& option = "--out");

// Installs handlers of SIGINT, SIGTERM and SIGHUP that remove the temporaries of
// every OutputSet and of the report plots, then end the process by the same
// signal. The command line installs them once at start.
void install_cleanup_handlers();

// Flushes standard output; throws InputError("standard output", ...) when a write
// to it failed (e.g. it is /dev/full or a closed pipe).
void finish_stdout();

namespace internal {
// Temporaries known to the signal handlers (files removed, then directories).
// Registration is async-signal-safe to read; a slot is released by unregister.
int register_temporary(const std::string& path, bool directory = false);
void unregister_temporary(int slot);
}  // namespace internal

}  // namespace dbbkit::io
