// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Output folders that are never seen half-written, whatever happens to the
/// process (an error, a full disk, SIGKILL, a power cut after the rename):
/// commands write into the sibling `<target>.partial` and swap it into place
/// at the end. On Linux the swap is one atomic renameat2(RENAME_EXCHANGE):
/// a reader sees the previous folder or the new one, never neither. Where the
/// file system cannot exchange, the previous folder moves aside to
/// `<target>.old` first; should the process die in that gap, the next run
/// puts `<target>.old` back before anything else (recoverInterruptedOutput).

#include <filesystem>

#include "core/status.h"

namespace cityatlas {

/// Undoes what an interrupted run left: `<target>.old` without `<target>`
/// becomes `<target>` again; a stale `<target>.partial` and a `<target>.old`
/// beside a complete `<target>` are removed.
Status recoverInterruptedOutput(const std::filesystem::path& target);

/// recoverInterruptedOutput(), then the working folder `<target>.partial`,
/// emptied and created (with `subfolder` inside when given). The error names
/// the folder.
Status startWorkingFolder(const std::filesystem::path& target, const std::filesystem::path& subfolder,
                          std::filesystem::path* working);

/// Moves the finished folder `finished` to `target`, replacing what is there
/// (see the file comment), and removes the previous output.
Status replaceFolder(const std::filesystem::path& finished, const std::filesystem::path& target);

}  // namespace cityatlas
