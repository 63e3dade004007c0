#include "amhmvs_mapping/ros/ros_conversions.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include <boost/make_shared.hpp>
#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_eigen/tf2_eigen.h>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/colormap.h"

namespace amhmvs_mapping {

namespace enc = sensor_msgs::image_encodings;

// The encodings read, and what each becomes: grey stays grey (1 channel),
// colour and Bayer mosaics become RGB (cv_bridge converts and debayers).
bool supportedEncoding(const std::string& encoding) {
  static const std::string* const kSupported[] = {&enc::MONO8,       &enc::MONO16,      &enc::RGB8,
                                                  &enc::BGR8,        &enc::RGBA8,       &enc::BGRA8,
                                                  &enc::BAYER_RGGB8, &enc::BAYER_BGGR8, &enc::BAYER_GBRG8,
                                                  &enc::BAYER_GRBG8};
  for (const std::string* supported : kSupported)
    if (encoding == *supported) return true;
  return false;
}

std::string imageFromMsg(const sensor_msgs::Image& msg, amhmvs::ImageU8* image) {
  if (!supportedEncoding(msg.encoding))
    return "unsupported encoding '" + msg.encoding + "' (mono8, mono16, rgb8, bgr8, rgba8, bgra8, bayer_*8)";
  if (msg.width == 0 || msg.height == 0) return "empty image";
  // cv_bridge trusts step and the data length: check them first.
  const size_t channel_bytes = enc::bitDepth(msg.encoding) / 8;
  const size_t row_bytes = static_cast<size_t>(msg.width) * enc::numChannels(msg.encoding) * channel_bytes;
  if (msg.step < row_bytes || msg.step % channel_bytes != 0 ||
      msg.data.size() < static_cast<size_t>(msg.step) * msg.height) {
    std::ostringstream out;
    out << "image data does not match its size: " << msg.width << "x" << msg.height << " " << msg.encoding
        << " step " << msg.step << ", " << msg.data.size() << " bytes";
    return out.str();
  }
  const bool grey = msg.encoding == enc::MONO8 || msg.encoding == enc::MONO16;
  cv_bridge::CvImageConstPtr converted;
  try {
    converted = cv_bridge::toCvCopy(msg, grey ? enc::MONO8 : enc::RGB8);
  } catch (const cv_bridge::Exception& e) {
    return std::string("cv_bridge: ") + e.what();
  } catch (const cv::Exception& e) {
    return std::string("OpenCV: ") + e.what();
  }
  const cv::Mat& mat = converted->image;
  const int channels = mat.channels();
  *image = amhmvs::ImageU8(mat.cols, mat.rows, channels);
  for (int y = 0; y < mat.rows; ++y)
    std::memcpy(image->data.data() + static_cast<size_t>(y) * mat.cols * channels, mat.ptr<uint8_t>(y),
                static_cast<size_t>(mat.cols) * channels);
  return "";
}

std::string poseFromMsg(const geometry_msgs::Pose& msg, Eigen::Isometry3d* camera_to_world) {
  const auto& p = msg.position;
  const auto& q = msg.orientation;
  for (double v : {p.x, p.y, p.z, q.x, q.y, q.z, q.w})
    if (!std::isfinite(v)) return "pose has a non-finite value";
  const Eigen::Quaterniond quaternion(q.w, q.x, q.y, q.z);
  const double norm = quaternion.norm();
  if (std::abs(norm - 1.0) > 1e-3) {
    std::ostringstream out;
    out << "pose is not rigid: quaternion norm " << norm << " (must be 1)";
    return out.str();
  }
  geometry_msgs::Pose rigid = msg;
  rigid.orientation = tf2::toMsg(quaternion.normalized());
  tf2::fromMsg(rigid, *camera_to_world);
  return "";
}

geometry_msgs::Pose poseToMsg(const Eigen::Isometry3d& camera_to_world) { return tf2::toMsg(camera_to_world); }

std::string cameraFromMsg(const sensor_msgs::CameraInfo& info, int width, int height,
                          const Eigen::Isometry3d& camera_to_world, amhmvs::PinholeCamera* camera,
                          bool* distorted) {
  if (static_cast<int>(info.width) != width || static_cast<int>(info.height) != height) {
    std::ostringstream out;
    out << "camera_info size " << info.width << "x" << info.height << " does not match the image "
        << width << "x" << height;
    return out.str();
  }
  // Every number of the message must be finite, also those not used here.
  const auto allFinite = [](const auto& values) {
    return std::all_of(std::begin(values), std::end(values), [](double v) { return std::isfinite(v); });
  };
  if (!allFinite(info.D)) return "camera_info D has a non-finite value";
  if (!allFinite(info.R)) return "camera_info R has a non-finite value";
  if (!allFinite(info.P)) return "camera_info P has a non-finite value";
  amhmvs::PinholeCamera c;
  c.fx = info.K[0];
  c.fy = info.K[4];
  c.cx = info.K[2];
  c.cy = info.K[5];
  c.width = width;
  c.height = height;
  if (!(std::isfinite(c.fx) && std::isfinite(c.fy) && c.fx > 0 && c.fy > 0 && std::isfinite(c.cx) &&
        std::isfinite(c.cy)))
    return "camera_info K has no positive finite focal length or a non-finite principal point";
  const Eigen::Isometry3d world_to_camera = camera_to_world.inverse();
  c.R = world_to_camera.linear();
  c.t = world_to_camera.translation();
  const std::string problem = c.validate();
  if (!problem.empty()) return "camera: " + problem;
  if (distorted) {
    *distorted = false;
    for (double d : info.D)
      if (d != 0) *distorted = true;
  }
  *camera = c;
  return "";
}

namespace {

// A depth image message of `depth`'s size, one Pixel per pixel of
// convert(depth value).
template <typename Pixel, typename Convert>
sensor_msgs::ImagePtr depthMsg(const amhmvs::ImageF& depth, const std_msgs::Header& header,
                               const std::string& encoding, Convert convert) {
  auto msg = boost::make_shared<sensor_msgs::Image>();
  msg->header = header;
  msg->width = depth.width;
  msg->height = depth.height;
  msg->encoding = encoding;
  msg->is_bigendian = false;
  msg->step = depth.width * sizeof(Pixel);
  msg->data.resize(static_cast<size_t>(msg->step) * depth.height);
  Pixel* out = reinterpret_cast<Pixel*>(msg->data.data());
  for (size_t i = 0; i < depth.pixelCount(); ++i) out[i] = convert(depth.data[i * depth.channels]);
  return msg;
}

}  // namespace

sensor_msgs::ImagePtr depthImageMsg(const amhmvs::ImageF& depth, const std_msgs::Header& header) {
  return depthMsg<float>(depth, header, enc::TYPE_32FC1, [](float d) {
    return std::isfinite(d) && d > 0 ? d : std::numeric_limits<float>::quiet_NaN();
  });
}

sensor_msgs::ImagePtr depthImageMillimetresMsg(const amhmvs::ImageF& depth, const std_msgs::Header& header) {
  return depthMsg<uint16_t>(depth, header, enc::TYPE_16UC1, [](float d) {
    const double millimetres = std::round(1000.0 * d);
    const bool fits = std::isfinite(millimetres) && millimetres >= 1 && millimetres <= 65535;
    return fits ? static_cast<uint16_t>(millimetres) : uint16_t{0};
  });
}

sensor_msgs::CameraInfoPtr cameraInfoMsg(const amhmvs::PinholeCamera& camera, const std_msgs::Header& header) {
  auto msg = boost::make_shared<sensor_msgs::CameraInfo>();
  msg->header = header;
  msg->width = camera.width;
  msg->height = camera.height;
  msg->distortion_model = "plumb_bob";
  msg->D.assign(5, 0.0);
  msg->K = {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1};
  msg->R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  msg->P = {camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0};
  return msg;
}

sensor_msgs::ImagePtr confidenceImageMsg(const amhmvs::DepthMap& map, const std_msgs::Header& header) {
  auto msg = depthImageMsg(map.depth, header);
  float* out = reinterpret_cast<float*>(msg->data.data());
  for (size_t i = 0; i < map.depth.pixelCount(); ++i) {
    const float cost = i < map.cost.data.size() ? map.cost.data[i] : NAN;
    out[i] = std::isfinite(out[i]) && std::isfinite(cost) ? std::clamp(1.0f - cost / 2.0f, 0.0f, 1.0f) : 0.0f;
  }
  return msg;
}

sensor_msgs::ImagePtr confidenceImageMsg(const amhmvs::PublishedDepth& published, const std_msgs::Header& header) {
  return depthMsg<float>(published.confidence, header, enc::TYPE_32FC1,
                         [](float p) { return std::isfinite(p) ? std::clamp(p, 0.0f, 1.0f) : 0.0f; });
}

sensor_msgs::ImagePtr depthPreviewMsg(const amhmvs::ImageF& depth, const std_msgs::Header& header) {
  std::pair<float, float> range;
  try {
    range = amhmvs::robustRange(depth);
  } catch (const amhmvs::InputError&) {
    return nullptr;  // no finite pixel
  }
  const amhmvs::ImageU8 rgb = amhmvs::colorizeDepth(depth, range.first, range.second);
  auto msg = boost::make_shared<sensor_msgs::Image>();
  msg->header = header;
  msg->width = rgb.width;
  msg->height = rgb.height;
  msg->encoding = enc::BGR8;
  msg->step = rgb.width * 3;
  msg->data.resize(static_cast<size_t>(msg->step) * rgb.height);
  for (size_t i = 0; i < rgb.pixelCount(); ++i) {
    msg->data[3 * i] = rgb.data[3 * i + 2];
    msg->data[3 * i + 1] = rgb.data[3 * i + 1];
    msg->data[3 * i + 2] = rgb.data[3 * i];
  }
  return msg;
}

amhmvs::PointCloud keyframeCloud(const amhmvs::KeyframePoints& points) {
  amhmvs::PointCloud cloud;
  cloud.points.reserve(points.size());
  cloud.normals.reserve(points.size());
  cloud.colors.reserve(points.size());
  cloud.confidence.reserve(points.size());
  for (const amhmvs::KeyframePoint& point : points) {
    cloud.points.push_back(point.position);
    cloud.normals.push_back(point.normal);
    cloud.colors.push_back({point.rgb[0], point.rgb[1], point.rgb[2]});
    cloud.confidence.push_back(point.confidence);
  }
  return cloud;
}

visualization_msgs::MarkerPtr meshMarkerMsg(const amhmvs::TriangleMesh& mesh, const std_msgs::Header& header) {
  auto msg = boost::make_shared<visualization_msgs::Marker>();
  msg->header = header;
  msg->ns = "surface";
  msg->id = 0;
  msg->type = visualization_msgs::Marker::TRIANGLE_LIST;
  msg->action = visualization_msgs::Marker::ADD;
  msg->pose.orientation.w = 1;
  msg->scale.x = msg->scale.y = msg->scale.z = 1;
  msg->color.r = msg->color.g = msg->color.b = 0.8f;
  msg->color.a = 1;
  const amhmvs::PointCloud& vertices = mesh.vertices;
  const bool coloured = vertices.colors.size() == vertices.size();
  msg->points.reserve(3 * mesh.triangles.size());
  if (coloured) msg->colors.reserve(3 * mesh.triangles.size());
  for (const std::array<uint32_t, 3>& triangle : mesh.triangles) {
    bool finite = true;
    for (uint32_t index : triangle) finite = finite && index < vertices.size() && vertices.points[index].allFinite();
    if (!finite) continue;
    for (uint32_t index : triangle) {
      geometry_msgs::Point point;
      point.x = vertices.points[index].x();
      point.y = vertices.points[index].y();
      point.z = vertices.points[index].z();
      msg->points.push_back(point);
      if (!coloured) continue;
      std_msgs::ColorRGBA colour;
      colour.r = vertices.colors[index][0] / 255.0f;
      colour.g = vertices.colors[index][1] / 255.0f;
      colour.b = vertices.colors[index][2] / 255.0f;
      colour.a = 1;
      msg->colors.push_back(colour);
    }
  }
  return msg;
}

sensor_msgs::PointCloud2Ptr cloudMsg(const amhmvs::PointCloud& cloud, const std_msgs::Header& header) {
  const bool has_normals = cloud.normals.size() == cloud.size(), has_colors = cloud.colors.size() == cloud.size();
  auto finite = [&](size_t i) { return cloud.points[i].allFinite() && (!has_normals || cloud.normals[i].allFinite()); };
  size_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) count += finite(i);

  auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
  msg->header = header;
  sensor_msgs::PointCloud2Modifier modifier(*msg);
  modifier.setPointCloud2Fields(7, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1,
                                sensor_msgs::PointField::FLOAT32, "z", 1, sensor_msgs::PointField::FLOAT32,
                                "rgb", 1, sensor_msgs::PointField::FLOAT32, "normal_x", 1,
                                sensor_msgs::PointField::FLOAT32, "normal_y", 1,
                                sensor_msgs::PointField::FLOAT32, "normal_z", 1,
                                sensor_msgs::PointField::FLOAT32);
  modifier.resize(count);
  msg->height = 1;
  msg->width = count;
  msg->is_dense = true;
  sensor_msgs::PointCloud2Iterator<float> it_x(*msg, "x"), it_y(*msg, "y"), it_z(*msg, "z");
  sensor_msgs::PointCloud2Iterator<float> it_rgb(*msg, "rgb");
  sensor_msgs::PointCloud2Iterator<float> it_nx(*msg, "normal_x"), it_ny(*msg, "normal_y"), it_nz(*msg, "normal_z");
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!finite(i)) continue;  // never a NaN in a cloud
    *it_x = cloud.points[i].x();
    *it_y = cloud.points[i].y();
    *it_z = cloud.points[i].z();
    const std::array<uint8_t, 3> c = has_colors ? cloud.colors[i] : std::array<uint8_t, 3>{0, 0, 0};
    const uint32_t packed = (uint32_t{c[0]} << 16) | (uint32_t{c[1]} << 8) | c[2];
    float packed_float;
    std::memcpy(&packed_float, &packed, sizeof(float));
    *it_rgb = packed_float;
    const Eigen::Vector3f normal = has_normals ? cloud.normals[i] : Eigen::Vector3f::Zero();
    *it_nx = normal.x();
    *it_ny = normal.y();
    *it_nz = normal.z();
    ++it_x, ++it_y, ++it_z, ++it_rgb, ++it_nx, ++it_ny, ++it_nz;
  }
  return msg;
}

}  // namespace amhmvs_mapping
