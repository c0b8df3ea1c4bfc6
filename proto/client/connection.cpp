#include "client/connection.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <capnp/rpc.h>

namespace sculpt::client {

capnp::ReaderOptions client_reader_options() {
  capnp::ReaderOptions o;
  o.traversalLimitInWords = std::uint64_t{1} << 27;  // 1 GiB
  o.nestingLimit = 64;
  return o;
}

namespace {

// A blocking connect (a Unix socket connects at once or fails), so that a
// missing daemon gets a plain, specific message.
int connect_unix(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof(addr.sun_path))
    throw ClientError(ClientError::Kind::failed, "socket path too long (" + std::to_string(path.size()) +
                                                     " bytes, at most " + std::to_string(sizeof(addr.sun_path) - 1) +
                                                     "): " + path);
  std::memcpy(addr.sun_path, path.data(), path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw ClientError(ClientError::Kind::failed, std::string("socket: ") + std::strerror(errno));
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    if (err == ENOENT || err == ECONNREFUSED || err == ENOTDIR)
      throw ClientError(ClientError::Kind::no_daemon, "no daemon is listening on " + path);
    if (err == EACCES || err == EPERM)
      throw ClientError(ClientError::Kind::failed, "no permission to connect to " + path +
                                                       " (the sculptd group may connect)");
    throw ClientError(ClientError::Kind::failed, "cannot connect to " + path + ": " + std::strerror(err));
  }
  return fd;
}

}  // namespace

Connection::Connection(kj::AsyncIoContext& io, const std::string& socket_path, const std::string& client_name,
                       std::uint16_t major, std::uint16_t minor)
    : io_(io), path_(socket_path) {
  const int fd = connect_unix(socket_path);
  stream_ = io.lowLevelProvider->wrapSocketFd(fd, kj::LowLevelAsyncIoProvider::TAKE_OWNERSHIP);
  network_ = kj::heap<capnp::TwoPartyVatNetwork>(*stream_, capnp::rpc::twoparty::Side::CLIENT,
                                                 client_reader_options());
  rpc_ = kj::heap<capnp::RpcSystem<capnp::rpc::twoparty::VatId>>(capnp::makeRpcClient(*network_));
  capnp::word scratch[4]{};
  capnp::MallocMessageBuilder vat(scratch);
  auto id = vat.getRoot<capnp::rpc::twoparty::VatId>();
  id.setSide(capnp::rpc::twoparty::Side::SERVER);
  auto sculptd = rpc_->bootstrap(id).castAs<proto::Sculptd>();

  auto req = sculptd.helloRequest();
  req.setMajor(major);
  req.setMinor(minor);
  req.setClient(client_name);
  // Something listens (connect worked): a connection closed before the
  // answer is the daemon's doing (a limit, see its log), not "no daemon".
  auto reply = [&] {
    try {
      return req.send().wait(io.waitScope);
    } catch (const kj::Exception& e) {
      throw ClientError(ClientError::Kind::failed,
                        "the daemon on " + socket_path + " closed the connection before answering hello (" +
                            e.getDescription().cStr() + "; its log says why)");
    }
  }();
  server_ = reply.getServer();
  server_minor_ = reply.getMinor();
  if (!reply.getAccepted()) {
    if (reply.getMajor() != major)
      throw ClientError(ClientError::Kind::incompatible,
                        "daemon speaks protocol " + std::to_string(reply.getMajor()) + ", this client " +
                            std::to_string(major) + " (" + std::string(reply.getReason().cStr()) + ")");
    throw ClientError(ClientError::Kind::refused, "daemon refused: " + std::string(reply.getReason().cStr()));
  }
  session_ = reply.getSession();
}

Connection::~Connection() = default;

}  // namespace sculpt::client
