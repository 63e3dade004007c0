// Whole files written so that no reader, crash, kill or full disk leaves half
// a file under the final name: the bytes go to a new temporary file in the
// same folder (so that the rename stays on one file system and is atomic),
// which is flushed, closed and renamed onto the path. A failed write removes
// its temporary file and leaves the file that had the name before untouched.
// Not synced to the disk: a power cut can still lose the newest file, as with
// most tools' outputs.
#pragma once

#include <string>

namespace amhmvs {

// Throws InputError naming the path, `what` (e.g. "depth map") and the
// system's reason (e.g. "No space left on device").
void writeFileAtomically(const std::string& path, const std::string& bytes, const std::string& what = "file");

}  // namespace amhmvs
