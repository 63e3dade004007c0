// A ROS 1 master (registration and parameter server, the XML-RPC API of
// rosmaster) in the test driver's own process, on xmlrpcpp, so that the
// nodelet can run on a machine without rosmaster (no Python there). Enough of
// the API for roscpp nodes on one host: register/unregister publishers,
// subscribers and services with publisherUpdate notifications, lookups,
// system state, and the parameter server (get/set/has/delete/search/
// subscribe/names; no paramUpdate notifications).
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <xmlrpcpp/XmlRpcServer.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace gpu_ros {

class MiniMaster {
 public:
  MiniMaster();
  ~MiniMaster();
  // Binds a free port from `first_port` on and serves in a thread.
  bool start(int first_port);
  void stop();
  std::string uri() const { return uri_; }

  // The parameter server, also for the driver itself (before ros::init).
  void setParam(const std::string& key, const XmlRpc::XmlRpcValue& value);
  bool getParam(const std::string& key, XmlRpc::XmlRpcValue* value) const;

 private:
  class Method;
  using Handler = std::function<XmlRpc::XmlRpcValue(XmlRpc::XmlRpcValue&)>;
  void add(const std::string& name, Handler handler);
  void serve();
  void notifyLoop();
  void notifySubscribers(const std::string& topic);  // lock held
  bool hasParamLocked(const std::string& key) const;
  void deleteParamLocked(const std::string& key);

  XmlRpc::XmlRpcServer server_;
  std::vector<std::unique_ptr<Method>> methods_;
  std::thread server_thread_, notify_thread_;
  bool stop_ = false;
  std::string uri_;

  mutable std::mutex mutex_;
  std::map<std::string, XmlRpc::XmlRpcValue> params_;            // leaf key -> value
  std::map<std::string, std::string> topic_types_;               // topic -> type
  std::map<std::string, std::map<std::string, std::string>> publishers_, subscribers_;  // topic -> node -> api
  std::map<std::string, std::pair<std::string, std::string>> services_;  // service -> (node, rosrpc uri)
  std::map<std::string, std::string> nodes_;                     // node -> api

  struct Update {
    std::string api, topic;
    std::vector<std::string> publishers;
  };
  std::mutex notify_mutex_;
  std::condition_variable notify_cv_;
  std::deque<Update> updates_;
};

}  // namespace gpu_ros
