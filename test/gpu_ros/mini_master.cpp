#include "mini_master.h"

#include <unistd.h>

#include <cstdio>

#include <xmlrpcpp/XmlRpcClient.h>
#include <xmlrpcpp/XmlRpcException.h>
#include <xmlrpcpp/XmlRpcServerMethod.h>

namespace gpu_ros {
namespace {

using XmlRpc::XmlRpcValue;

XmlRpcValue reply(int code, const std::string& message, const XmlRpcValue& value) {
  XmlRpcValue r;
  r[0] = code;
  r[1] = message;
  r[2] = value;
  return r;
}

XmlRpcValue emptyArray() {
  XmlRpcValue a;
  a.setSize(0);
  return a;
}

XmlRpcValue emptyStruct() {
  int offset = 0;
  return XmlRpcValue("<value><struct></struct></value>", &offset);
}

XmlRpcValue stringArray(const std::vector<std::string>& items) {
  XmlRpcValue a = emptyArray();
  for (size_t i = 0; i < items.size(); ++i) a[static_cast<int>(i)] = items[i];
  return a;
}

// "/a/b/" and "a/b" -> "/a/b"; "" -> "/".
std::string canonical(std::string key) {
  if (key.empty() || key[0] != '/') key = "/" + key;
  while (key.size() > 1 && key.back() == '/') key.pop_back();
  return key;
}

std::string namespaceOf(const std::string& name) {
  const std::string n = canonical(name);
  const size_t slash = n.rfind('/');
  return slash == 0 ? "/" : n.substr(0, slash);
}

bool under(const std::string& key, const std::string& prefix) {
  if (prefix == "/") return true;
  return key.compare(0, prefix.size(), prefix) == 0 && key.size() > prefix.size() && key[prefix.size()] == '/';
}

std::string str(XmlRpcValue& v) { return static_cast<std::string&>(v); }

}  // namespace

class MiniMaster::Method : public XmlRpc::XmlRpcServerMethod {
 public:
  Method(const std::string& name, XmlRpc::XmlRpcServer* server, Handler handler)
      : XmlRpc::XmlRpcServerMethod(name, server), handler_(std::move(handler)) {}
  void execute(XmlRpcValue& params, XmlRpcValue& result) override {
    try {
      result = handler_(params);
    } catch (const XmlRpc::XmlRpcException& e) {
      result = reply(-1, "bad arguments to " + _name + ": " + e.getMessage(), 0);
    }
  }

 private:
  Handler handler_;
};

MiniMaster::MiniMaster() {
  add("getPid", [](XmlRpcValue&) { return reply(1, "", static_cast<int>(getpid())); });
  add("getUri", [this](XmlRpcValue&) { return reply(1, "", uri_); });
  add("lookupNode", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = nodes_.find(canonical(str(p[1])));
    return it == nodes_.end() ? reply(-1, "unknown node", "") : reply(1, "", it->second);
  });
  add("registerPublisher", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string node = str(p[0]), topic = str(p[1]);
    topic_types_[topic] = str(p[2]);
    publishers_[topic][node] = nodes_[node] = str(p[3]);
    std::vector<std::string> subs;
    for (const auto& s : subscribers_[topic]) subs.push_back(s.second);
    notifySubscribers(topic);
    return reply(1, "registered " + node + " as publisher of " + topic, stringArray(subs));
  });
  add("unregisterPublisher", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string node = str(p[0]), topic = str(p[1]);
    const int removed = static_cast<int>(publishers_[topic].erase(node));
    if (removed) notifySubscribers(topic);
    return reply(1, "", removed);
  });
  add("registerSubscriber", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string node = str(p[0]), topic = str(p[1]), type = str(p[2]);
    if (!topic_types_.count(topic) || topic_types_[topic] == "*") topic_types_[topic] = type;
    subscribers_[topic][node] = nodes_[node] = str(p[3]);
    std::vector<std::string> pubs;
    for (const auto& s : publishers_[topic]) pubs.push_back(s.second);
    return reply(1, "subscribed", stringArray(pubs));
  });
  add("unregisterSubscriber", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    return reply(1, "", static_cast<int>(subscribers_[str(p[1])].erase(str(p[0]))));
  });
  add("registerService", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string node = str(p[0]);
    services_[str(p[1])] = {node, str(p[2])};
    nodes_[node] = str(p[3]);
    return reply(1, "", 1);
  });
  add("unregisterService", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = services_.find(str(p[1]));
    if (it == services_.end() || it->second.second != str(p[2])) return reply(1, "", 0);
    services_.erase(it);
    return reply(1, "", 1);
  });
  add("lookupService", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = services_.find(str(p[1]));
    return it == services_.end() ? reply(-1, "no provider", "") : reply(1, "", it->second.second);
  });
  auto topicList = [this](bool published_only) {
    std::lock_guard<std::mutex> lock(mutex_);
    XmlRpcValue list = emptyArray();
    int i = 0;
    for (const auto& t : topic_types_) {
      if (published_only && publishers_[t.first].empty()) continue;
      list[i][0] = t.first;
      list[i][1] = t.second;
      ++i;
    }
    return reply(1, "", list);
  };
  add("getPublishedTopics", [topicList](XmlRpcValue&) { return topicList(true); });
  add("getTopicTypes", [topicList](XmlRpcValue&) { return topicList(false); });
  add("getSystemState", [this](XmlRpcValue&) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto entries = [](const std::map<std::string, std::map<std::string, std::string>>& m) {
      XmlRpcValue list = emptyArray();
      int i = 0;
      for (const auto& t : m) {
        if (t.second.empty()) continue;
        list[i][0] = t.first;
        std::vector<std::string> nodes;
        for (const auto& n : t.second) nodes.push_back(n.first);
        list[i][1] = stringArray(nodes);
        ++i;
      }
      return list;
    };
    XmlRpcValue state;
    state[0] = entries(publishers_);
    state[1] = entries(subscribers_);
    std::map<std::string, std::map<std::string, std::string>> services;
    for (const auto& s : services_) services[s.first][s.second.first] = s.second.second;
    state[2] = entries(services);
    return reply(1, "", state);
  });

  add("setParam", [this](XmlRpcValue& p) {
    setParam(str(p[1]), p[2]);
    return reply(1, "", 0);
  });
  add("getParam", [this](XmlRpcValue& p) {
    XmlRpcValue v;
    if (!getParam(str(p[1]), &v)) return reply(-1, "Parameter [" + str(p[1]) + "] is not set", 0);
    return reply(1, "", v);
  });
  add("subscribeParam", [this](XmlRpcValue& p) {
    XmlRpcValue v;
    if (!getParam(str(p[2]), &v)) v = emptyStruct();
    return reply(1, "", v);
  });
  add("unsubscribeParam", [](XmlRpcValue&) { return reply(1, "", 1); });
  add("hasParam", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    return reply(1, str(p[1]), hasParamLocked(canonical(str(p[1]))));
  });
  add("deleteParam", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string key = canonical(str(p[1]));
    if (!hasParamLocked(key)) return reply(-1, "parameter [" + key + "] is not set", 0);
    deleteParamLocked(key);
    return reply(1, "", 0);
  });
  add("searchParam", [this](XmlRpcValue& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string key = str(p[1]);
    if (!key.empty() && key[0] == '/') return hasParamLocked(canonical(key)) ? reply(1, "", key) : reply(-1, "", "");
    const std::string first = key.substr(0, key.find('/'));
    for (std::string ns = namespaceOf(str(p[0]));; ns = namespaceOf(ns)) {
      const std::string candidate = canonical((ns == "/" ? "" : ns) + "/" + first);
      if (hasParamLocked(candidate)) return reply(1, "", canonical((ns == "/" ? "" : ns) + "/" + key));
      if (ns == "/") break;
    }
    return reply(-1, "not found", "");
  });
  add("getParamNames", [this](XmlRpcValue&) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::string> names;
    for (const auto& p : params_) names.push_back(p.first);
    return reply(1, "", stringArray(names));
  });
}

MiniMaster::~MiniMaster() { stop(); }

void MiniMaster::add(const std::string& name, Handler handler) {
  methods_.emplace_back(new Method(name, &server_, std::move(handler)));
}

bool MiniMaster::start(int first_port) {
  for (int port = first_port; port < first_port + 200; ++port) {
    if (!server_.bindAndListen(port)) continue;
    uri_ = "http://127.0.0.1:" + std::to_string(port) + "/";
    server_thread_ = std::thread([this] { serve(); });
    notify_thread_ = std::thread([this] { notifyLoop(); });
    return true;
  }
  return false;
}

void MiniMaster::serve() {
  while (true) {
    {
      std::lock_guard<std::mutex> lock(notify_mutex_);
      if (stop_) break;
    }
    server_.work(0.05);
  }
  server_.shutdown();
}

void MiniMaster::stop() {
  {
    std::lock_guard<std::mutex> lock(notify_mutex_);
    stop_ = true;
  }
  notify_cv_.notify_all();
  if (server_thread_.joinable()) server_thread_.join();
  if (notify_thread_.joinable()) notify_thread_.join();
}

void MiniMaster::notifySubscribers(const std::string& topic) {
  Update update;
  update.topic = topic;
  for (const auto& p : publishers_[topic]) update.publishers.push_back(p.second);
  std::lock_guard<std::mutex> lock(notify_mutex_);
  for (const auto& s : subscribers_[topic]) {
    update.api = s.second;
    updates_.push_back(update);
  }
  notify_cv_.notify_all();
}

// publisherUpdate calls to the subscribers' nodes, outside the server thread
// (as rosmaster does), so that a node registering a publisher never waits on
// a call into its own XML-RPC server.
void MiniMaster::notifyLoop() {
  while (true) {
    Update update;
    {
      std::unique_lock<std::mutex> lock(notify_mutex_);
      notify_cv_.wait(lock, [this] { return stop_ || !updates_.empty(); });
      if (stop_) return;
      update = updates_.front();
      updates_.pop_front();
    }
    // http://host:port/
    const std::string rest = update.api.substr(update.api.find("://") + 3);
    const size_t colon = rest.find(':');
    const std::string host = rest.substr(0, colon);
    const int port = std::atoi(rest.c_str() + colon + 1);
    XmlRpc::XmlRpcClient client(host.c_str(), port, "/");
    XmlRpcValue params, result;
    params[0] = "/master";
    params[1] = update.topic;
    params[2] = stringArray(update.publishers);
    if (!client.execute("publisherUpdate", params, result))
      std::fprintf(stderr, "mini master: publisherUpdate of %s to %s failed\n", update.topic.c_str(),
                   update.api.c_str());
    client.close();
  }
}

void MiniMaster::setParam(const std::string& raw_key, const XmlRpcValue& value) {
  const std::string key = canonical(raw_key);
  std::lock_guard<std::mutex> lock(mutex_);
  deleteParamLocked(key);
  // A leaf above the key is replaced by the namespace.
  for (std::string ns = namespaceOf(key); ns != "/"; ns = namespaceOf(ns)) params_.erase(ns);
  std::vector<std::pair<std::string, XmlRpcValue>> todo = {{key, value}};
  while (!todo.empty()) {
    std::pair<std::string, XmlRpcValue> item = todo.back();
    todo.pop_back();
    if (item.second.getType() == XmlRpcValue::TypeStruct && item.second.size() > 0) {
      for (auto& member : item.second)
        todo.push_back({canonical(item.first + "/" + member.first), member.second});
    } else {
      params_[item.first] = item.second;
    }
  }
}

bool MiniMaster::getParam(const std::string& raw_key, XmlRpcValue* value) const {
  const std::string key = canonical(raw_key);
  std::lock_guard<std::mutex> lock(mutex_);
  const auto leaf = params_.find(key);
  if (leaf != params_.end()) {
    *value = leaf->second;
    return true;
  }
  XmlRpcValue tree = emptyStruct();
  bool found = false;
  for (const auto& p : params_) {
    if (!under(p.first, key)) continue;
    found = true;
    const std::string rest = p.first.substr(key == "/" ? 1 : key.size() + 1);
    XmlRpcValue* node = &tree;
    size_t start = 0;
    while (true) {
      const size_t slash = rest.find('/', start);
      const std::string part = rest.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
      if (slash == std::string::npos) {
        (*node)[part] = p.second;
        break;
      }
      if (!node->hasMember(part)) (*node)[part] = emptyStruct();
      node = &(*node)[part];
      start = slash + 1;
    }
  }
  if (found || key == "/") *value = tree;
  return found || key == "/";
}

bool MiniMaster::hasParamLocked(const std::string& key) const {
  if (key == "/" || params_.count(key)) return true;
  const auto it = params_.lower_bound(key + "/");
  return it != params_.end() && under(it->first, key);
}

void MiniMaster::deleteParamLocked(const std::string& key) {
  for (auto it = params_.begin(); it != params_.end();) {
    if (it->first == key || under(it->first, key))
      it = params_.erase(it);
    else
      ++it;
  }
}

}  // namespace gpu_ros
