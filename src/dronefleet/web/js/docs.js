// Starts Swagger UI on /docs (ground/manager/docs.py): a script file, not an inline one, so the
// page's Content-Security-Policy allows scripts from this server only.
(function () {
  "use strict";
  const root = document.getElementById("swagger-ui");
  if (typeof window.SwaggerUIBundle !== "function") {
    // scripts/web-deps.sh has not copied Swagger UI in: say so rather than show a blank page.
    document.getElementById("docs-missing").hidden = false;
    return;
  }
  window.ui = window.SwaggerUIBundle({
    url: root.dataset.openapi,
    domNode: root,
    layout: "BaseLayout",
    presets: [window.SwaggerUIBundle.presets.apis],
    deepLinking: true,
    showExtensions: true,
    showCommonExtensions: true,
    validatorUrl: null, // never ask validator.swagger.io about this API
  });
})();
