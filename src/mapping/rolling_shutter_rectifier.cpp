#include "amhmvs_mapping/mapping/rolling_shutter_rectifier.h"

#include <algorithm>
#include <utility>

namespace amhmvs {
namespace {

// A change below this much turn over a readout moves no pixel by more than a
// few hundredths (1e-4 rad x a focal length of a few hundred px); nor does
// this much shift of a row's centre (1e-4 m at 2 m).
constexpr double kMinRectificationChange = 1e-4;

}  // namespace

void RollingShutterRectifier::setOptions(const RollingShutterOptions& options, bool adjusted) {
  options_ = options;
  adjusted_ = adjusted;
}

void RollingShutterRectifier::rectifyStored(int64_t id, uint64_t estimates_started, KeyframeStore* store) {
  if (!options_.enabled()) return;
  const Keyframe& stored = store->keyframe(id);
  if (options_.use_tracker_velocity && stored.velocity) {  // no estimate from the previous pose
    motion_anchor_ = {true, id, stored.stamp, stored.camera, true, estimates_started};
    if (adjusted_ && options_.solvesTrackerVelocity())
      rerectifiable_[id] = {stored.image, stored.velocity->angular, *stored.velocity};
    store->replaceImage(id, rectifyRollingShutter(stored.image, stored.camera, stored.velocity->angular,
                                                  options_.readout_s));
    if (options_.translation) store->setMotion(id, {stored.velocity->linear, options_.readout_s});
    ++rectified_;
    ++from_tracker_velocity_;
    return;
  }
  const MotionAnchor previous = motion_anchor_;
  motion_anchor_ = {true, id, stored.stamp, stored.camera, false, estimates_started};
  const double interval = stored.stamp - previous.stamp;
  if (!previous.set || !(interval > 0) || interval > options_.max_interval_s) {
    ++not_rectified_;
    return;
  }
  const Eigen::Vector3d angular_velocity = cameraAngularVelocity(previous.camera, stored.camera, interval);
  const bool rectified_again_later = options_.from_adjusted_poses && adjusted_;
  const auto rectifyInStore = [&](int64_t key) {
    const Keyframe& keyframe = store->keyframe(key);
    if (rectified_again_later) rerectifiable_[key] = {keyframe.image, angular_velocity, std::nullopt};
    store->replaceImage(key, rectifyRollingShutter(keyframe.image, keyframe.camera, angular_velocity,
                                                   options_.readout_s));
    ++rectified_;
  };
  rectifyInStore(id);
  motion_anchor_.rectified = true;
  // The first keyframe of a run had no motion to go by; nothing has read its image yet.
  if (!previous.rectified && previous.estimates_started == estimates_started && store->contains(previous.id)) {
    rectifyInStore(previous.id);
    --not_rectified_;
  }
}

std::map<int64_t, VelocityPrior> RollingShutterRectifier::velocityPriors(const KeyframeStore& store) const {
  std::map<int64_t, VelocityPrior> priors;
  for (const auto& [id, rectified] : rerectifiable_) {
    if (!rectified.tracker_velocity || !store.contains(id)) continue;
    VelocityPrior& prior = priors[id];
    prior.angular_sigma_rad_s = options_.tracker_velocity_sigma_rad_s;
    prior.linear_sigma_m_s = options_.tracker_velocity_sigma_m_s;
    prior.offset.angular = rectified.angular_velocity - rectified.tracker_velocity->angular;
    prior.offset.linear = store.entry(id).motion.velocity - rectified.tracker_velocity->linear;
  }
  return priors;
}

void RollingShutterRectifier::planFromVelocities(const std::map<int64_t, CameraVelocity>& corrections,
                                                 const KeyframeStore& store,
                                                 const ReestimatePredicate& reestimates_left) {
  for (const auto& [id, correction] : corrections) {
    const auto rectified = rerectifiable_.find(id);
    if (rectified == rerectifiable_.end() || !store.contains(id)) continue;
    // A depth map that is not estimated again keeps the image it was estimated from.
    if (!reestimates_left(id) || std::max(correction.angular.norm(), correction.linear.norm()) * options_.readout_s <=
                                     kMinRectificationChange) {
      due_.erase(id);
      continue;
    }
    due_[id] = {rectified->second.angular_velocity + correction.angular,
                Eigen::Vector3d(store.entry(id).motion.velocity + correction.linear)};
  }
}

void RollingShutterRectifier::planFromPoses(const std::map<int64_t, Eigen::Isometry3d>& poses,
                                            const KeyframeStore& store,
                                            const ReestimatePredicate& reestimates_left) {
  if (rerectifiable_.empty()) return;
  std::vector<std::pair<double, int64_t>> by_time;
  for (const auto& entry : poses)
    if (store.contains(entry.first)) by_time.emplace_back(store.keyframe(entry.first).stamp, entry.first);
  std::sort(by_time.begin(), by_time.end());
  for (size_t i = 0; i < by_time.size(); ++i) {
    const auto rectified = rerectifiable_.find(by_time[i].second);
    // Keyframes with the tracker's velocity: planFromVelocities.
    if (rectified == rerectifiable_.end() || rectified->second.tracker_velocity) continue;
    // A depth map that is not estimated again keeps the image it was estimated from.
    if (!reestimates_left(rectified->first)) {
      due_.erase(rectified->first);
      continue;
    }
    // The mean of the chords to the keyframes before and after (each turn's
    // axis is the same in both of its cameras' frames).
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int chords = 0;
    const auto addChord = [&](size_t earlier, size_t later) {
      const double seconds = by_time[later].first - by_time[earlier].first;
      if (!(seconds > 0) || seconds > options_.max_interval_s) return;
      sum += cameraAngularVelocity(poses.at(by_time[earlier].second).linear(), poses.at(by_time[later].second).linear(),
                                   seconds);
      ++chords;
    };
    if (i > 0) addChord(i - 1, i);
    if (i + 1 < by_time.size()) addChord(i, i + 1);
    if (chords == 0) continue;
    const Eigen::Vector3d wanted = sum / chords;
    if ((wanted - rectified->second.angular_velocity).norm() * options_.readout_s > kMinRectificationChange)
      due_[rectified->first] = {wanted, std::nullopt};
    else
      due_.erase(rectified->first);
  }
}

std::vector<ImageRectifiedAgain> RollingShutterRectifier::rectifyDueAgain(KeyframeStore* store) {
  std::vector<ImageRectifiedAgain> done;
  for (const auto& [id, due] : due_) {
    const auto rectified = rerectifiable_.find(id);
    if (rectified == rerectifiable_.end() || !store->contains(id)) continue;
    ImageRectifiedAgain again{id, store->keyframe(id).camera, rectified->second.angular_velocity,
                              due.angular_velocity};
    store->replaceImage(id, rectifyRollingShutter(rectified->second.unrectified, again.camera, again.wanted,
                                                  options_.readout_s));
    rectified->second.angular_velocity = again.wanted;
    if (due.linear_velocity) store->setMotion(id, {*due.linear_velocity, options_.readout_s});
    ++image_revisions_[id];
    ++rectified_again_;
    done.push_back(std::move(again));
  }
  due_.clear();
  return done;
}

int RollingShutterRectifier::imageRevision(int64_t id) const {
  const auto found = image_revisions_.find(id);
  return found != image_revisions_.end() ? found->second : 0;
}

void RollingShutterRectifier::forget(int64_t id) {
  rerectifiable_.erase(id);
  due_.erase(id);
  image_revisions_.erase(id);
}

void RollingShutterRectifier::reset() {
  const RollingShutterOptions options = options_;
  const bool adjusted = adjusted_;
  *this = RollingShutterRectifier();
  setOptions(options, adjusted);
}

}  // namespace amhmvs
