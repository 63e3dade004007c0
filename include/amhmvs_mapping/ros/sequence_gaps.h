// Messages that never arrived, told from the publisher's numbering: roscpp
// and rospy publishers number each message of a topic (header.seq, one up
// per message, rosbag play included), so a jump of k means k - 1 messages were
// lost on the way (a subscriber queue that overflowed, a dropped connection).
// A number that goes back is a new publisher: counting starts again.
#pragma once

#include <cstdint>

namespace amhmvs_mapping {

class SequenceGaps {
 public:
  // The messages missing before this one.
  uint64_t arrive(uint32_t seq) {
    const uint64_t missing = seen_ && seq > last_ + 1 ? uint64_t{seq} - last_ - 1 : 0;
    seen_ = true;
    last_ = seq;
    lost_ += missing;
    return missing;
  }
  uint64_t lost() const { return lost_; }

 private:
  bool seen_ = false;
  uint32_t last_ = 0;
  uint64_t lost_ = 0;
};

}  // namespace amhmvs_mapping
